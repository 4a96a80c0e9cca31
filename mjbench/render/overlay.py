"""The text overlay of a frame (time, speeds, voltage …), drawn with Pillow on a crop of the frame."""
from __future__ import annotations

import numpy as np


# ============================================================================ overlay
_FONTS = {}


def _font(size: int):
    from PIL import ImageFont
    if size not in _FONTS:
        try:
            from matplotlib import font_manager
            path = font_manager.findfont("DejaVu Sans Mono", fallback_to_default=True)
            _FONTS[size] = ImageFont.truetype(path, size)
        except Exception:  # pragma: no cover - no usable TrueType font
            _FONTS[size] = ImageFont.load_default()
    return _FONTS[size]


class TextBox:
    """Text in a fixed top-left panel of a frame.  The font is monospaced (DejaVu Sans Mono), so
    every character is rendered once by Pillow into an alpha mask and cached; a line is then the
    concatenation of its characters' masks, blended with NumPy (≈10× cheaper than drawing with
    Pillow on every frame)."""

    COLOR = np.array([20, 20, 30], np.float32)

    def __init__(self, width, height, nlines, scale=1.0):
        self.size = max(11, int(round(18 * scale)))
        self.pad = max(4, self.size // 3)
        self.line_h = int(self.size * 1.3)
        font = _font(self.size)
        try:
            self.adv = max(1, int(round(font.getlength("M"))))
        except AttributeError:  # pragma: no cover - bitmap default font
            self.adv = max(1, int(self.size * 0.62))
        self.w = min(width - 4, self.adv * 47 + 2 * self.pad)
        self.h = min(height - 4, nlines * self.line_h + 2 * self.pad)
        self.x0 = self.y0 = max(2, self.size // 2)
        self._glyphs = {}

    @property
    def band_px(self):
        return self.y0 + self.h

    def _glyph(self, ch):
        g = self._glyphs.get(ch)
        if g is None:
            from PIL import Image, ImageDraw
            img = Image.new("L", (self.adv, self.line_h), 0)
            ImageDraw.Draw(img).text((0, 0), ch, fill=255, font=_font(self.size))
            g = self._glyphs[ch] = np.asarray(img, dtype=np.float32) / 255.0
        return g

    def draw(self, frame, lines):
        y0, x0, h, w = self.y0, self.x0, self.h, self.w
        crop = frame[y0:y0 + h, x0:x0 + w]
        crop[:] = (crop.astype(np.uint16) * 3 // 10 + 178).astype(np.uint8)  # translucent white panel
        maxc = (w - 2 * self.pad) // self.adv
        for i, line in enumerate(lines):
            line = line[:maxc]
            if not line:
                continue
            a = np.hstack([self._glyph(c) for c in line])[..., None]
            top = self.pad + i * self.line_h
            reg = crop[top:top + a.shape[0], self.pad:self.pad + a.shape[1]]
            a = a[: reg.shape[0], : reg.shape[1]]
            reg[:] = (reg - (reg - self.COLOR) * a).astype(np.uint8)
        return frame
