"""Writing frames to a file: H.264 MP4 through imageio-ffmpeg or a GIF through Pillow, written
under a temporary name and checked; frame times; the summary of a video."""
from __future__ import annotations

import math
import os
import tempfile
import time

import numpy as np

from ..errors import ParameterError
from . import gl
from .gl import RenderError
from ..outputs import FILE_MODE, _test_hook


# ============================================================================ writers
def _frame_bar(total, out, progress):
    from tqdm import tqdm
    return tqdm(total=total, unit="frame", desc=f"render {os.path.basename(os.fspath(out))}",
                disable=not progress, leave=False)


def _video_info(nframes, fps, width, height, t0, out, **extra):
    """Numbers describing a written video (frames, seconds, throughput)."""
    wall = time.perf_counter() - t0
    return {"frames": nframes, "width": width, "height": height, "fps": fps, "duration_s": nframes / fps,
            "wall_s": wall, "frames_per_s": nframes / wall if wall > 0 else float("nan"), "gl": gl._GL_CHOICE,
            "path": os.fspath(out), **extra}


def _check_mp4(tmp, path):
    """Refuse an incomplete MP4 (ffmpeg could not write it whole, e.g. the disk is full): its
    top-level boxes must tile the file and hold ``ftyp``, ``moov`` (the index) and ``mdat``."""
    import errno
    import struct

    size = os.path.getsize(tmp)
    kinds, pos = set(), 0
    with open(tmp, "rb") as f:
        while pos < size:
            f.seek(pos)
            head = f.read(16)
            if len(head) < 8:
                break
            n, kind = struct.unpack(">I4s", head[:8])
            if n == 1 and len(head) == 16:
                n = struct.unpack(">Q", head[8:16])[0]
            elif n == 0:
                n = size - pos
            if n < 8 or pos + n > size:
                break
            kinds.add(kind)
            pos += n
    if pos != size or not {b"ftyp", b"moov", b"mdat"} <= kinds:
        st = os.statvfs(os.path.dirname(os.path.abspath(tmp)))
        if st.f_bavail * st.f_frsize < 1 << 20:
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), path)
        raise RenderError(f"--out {path}: ffmpeg did not write a complete MP4 ({size} bytes, boxes "
                          f"{sorted(k.decode('latin-1') for k in kinds)}); the video was not saved")


class VideoWriter:
    """MP4 (H.264 via imageio-ffmpeg's bundled ffmpeg) or GIF (Pillow), written atomically."""

    def __init__(self, path, width, height, fps, crf=23):
        self.path = os.fspath(path)
        self.ext = os.path.splitext(self.path)[1].lower()
        if self.ext not in (".mp4", ".gif"):
            raise ParameterError(f"--out {self.path!r}: the video file must end in .mp4 or .gif")
        folder = os.path.dirname(os.path.abspath(self.path))
        os.makedirs(folder, exist_ok=True)
        fd, self.tmp = tempfile.mkstemp(dir=folder, prefix=".tmp-", suffix=self.ext)
        os.close(fd)
        self.fps, self.n = float(fps), 0
        self._frames = []
        if self.ext == ".mp4":
            import imageio_ffmpeg
            self._gen = imageio_ffmpeg.write_frames(
                self.tmp, (int(width), int(height)), fps=self.fps, codec="libx264", quality=None,
                pix_fmt_in="rgb24", pix_fmt_out="yuv420p", macro_block_size=2,
                ffmpeg_log_level="fatal",  # its errors become one line of ours (write, close: _check_mp4)
                output_params=["-preset", "veryfast", "-crf", str(int(crf)), "-movflags", "+faststart"])
            self._gen.send(None)

    def write(self, frame):
        if self.ext == ".mp4":
            try:
                self._gen.send(np.ascontiguousarray(frame))
            except OSError as e:  # ffmpeg exited (imageio-ffmpeg: a broken pipe and its whole command line)
                raise self._ffmpeg_stopped(e) from None
        else:
            self._frames.append(frame.copy())
        self.n += 1

    def _ffmpeg_stopped(self, e: OSError) -> Exception:
        """One-line error for an ffmpeg that stopped reading frames: a full disk (the usual cause: it
        cannot write the file's header) as ENOSPC, for the CLI's disk-full message; else what failed."""
        import errno
        import shutil

        try:
            full = shutil.disk_usage(os.path.dirname(os.path.abspath(self.tmp))).free < 2 ** 20
        except OSError:
            full = False
        if full:
            return OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), self.path)
        first = str(e).strip().splitlines()[0] if str(e).strip() else type(e).__name__
        return RenderError(f"--out {self.path}: ffmpeg stopped writing the video after {self.n} frames ({first}); "
                           "the video was not saved")

    def close(self):
        try:
            if self.ext == ".mp4":
                self._gen.close()
            else:
                from PIL import Image
                imgs = [Image.fromarray(f).convert("P", palette=Image.Palette.ADAPTIVE, colors=128)
                        for f in self._frames]
                if not imgs:
                    raise RenderError("no frame to write")
                imgs[0].save(self.tmp, format="GIF", save_all=True, append_images=imgs[1:],
                             duration=int(round(1000 / self.fps)), loop=0, optimize=False)
            if self.ext == ".mp4":
                _check_mp4(self.tmp, self.path)  # ffmpeg reports a failed write (disk full) only on its log
            os.chmod(self.tmp, FILE_MODE)  # mkstemp creates 0600
            os.replace(self.tmp, self.path)
            _test_hook(os.path.basename(self.path))
        except BaseException:
            self.abort()
            raise

    def __enter__(self):
        return self

    def __exit__(self, exc_type, exc, tb):
        """Complete file on success, nothing on error (the temporary file is removed)."""
        if exc_type is None:
            self.close()
        else:
            self.abort()
        return False

    def abort(self):
        try:
            if self.ext == ".mp4":
                self._gen.close()
        except Exception:
            pass
        try:
            os.unlink(self.tmp)
        except OSError:
            pass


def frame_indices(t, fps: float, t_end: float | None = None) -> np.ndarray:
    """Indices into the recorded times ``t`` nearest to k/fps, k = 0..floor(t_end·fps)."""
    t = np.asarray(t, float)
    t_end = float(t[-1] if t_end is None else min(t_end, t[-1]))
    nfr = int(math.floor(t_end * fps + 1e-9)) + 1
    tk = np.arange(nfr) / fps
    idx = np.clip(np.searchsorted(t, tk), 1, len(t) - 1)
    left = t[idx - 1]
    idx = np.where(np.abs(tk - left) <= np.abs(t[idx] - tk), idx - 1, idx)
    return idx
