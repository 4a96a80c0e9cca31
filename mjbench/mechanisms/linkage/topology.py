"""The joint graph of a linkage description: structural checks and the MJCF's spanning tree.

:func:`topology_problems` lists what is wrong with a description before anything is solved
(unknown links and points, duplicate or self joints, zero-length links, the input joint, links
not connected to the frame), each message naming the element.  An input joint in no loop (a
pendulum) is an open chain; its mobility is counted at assembly (:mod:`.assembly`).

:class:`TreeMixin` (part of the compiled description, :mod:`.model`) chooses the kinematic tree of
the MJCF — Kruskal over the joints: the input joint, then prismatic joints, then revolute joints
to the ground, then the rest — oriented from the ground; every other joint closes a loop.
"""
from __future__ import annotations

import math
from collections import deque
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:  # (the description's validator calls topology_problems: no import at run time)
    from .description import LinkageParams

GROUND = "ground"


def _ref(text):
    """'link.point' → (link, point)."""
    if not isinstance(text, str) or text.count(".") != 1:
        return None, None
    a, b = text.split(".")
    return a, b


def _rot2(th):
    c, s = math.cos(th), math.sin(th)
    return np.array([[c, -s], [s, c]])


# ============================================================================ structural checks
def topology_problems(p: LinkageParams, extra_edges=()) -> list:
    """Structural problems of a description (unknown links/points, duplicates, zero-length links,
    input joint, connectivity), each naming the element.  ``extra_edges``: further (name, link 1,
    link 2, kind) edges of the graph (gear pairs couple their links)."""
    out = []
    edges = _reference_problems(p, out)
    out += _zero_length_links(p)
    if p.inputs is not None:  # several motors: each a revolute joint (the mobility is checked at assembly)
        for name in p.inputs:
            j = next((j for j in p.joints if j.name == name), None)
            if j is None:
                out.append(f"inputs: no joint {name!r} (joints: {', '.join(j.name for j in p.joints)})")
            elif j.type != "revolute":
                out.append(f"inputs: joint {name!r} must be revolute (a motor turns it)")
        if out:
            return out
        adj = _joint_graph(p, edges)
        lost = sorted(set(p.links) - _reachable(adj, GROUND))
        return [f"links {', '.join(lost)}: not connected to the ground through joints"] if lost else []
    jin = next((j for j in p.joints if j.name == p.input), None)
    out += _input_joint_problems(p, jin)
    if out:
        return out
    adj = _joint_graph(p, edges + list(extra_edges))
    lost = sorted(set(p.links) - _reachable(adj, GROUND))
    if lost:
        return [f"links {', '.join(lost)}: not connected to the ground through joints"]
    # an input joint in no closed loop (a pendulum: one link on a ground pivot) is an open chain: it
    # is valid when the mobility is 1 (counted at assembly, where extra freedoms are named)
    return out


def _reference_problems(p, out: list) -> list:
    """Appends to ``out`` the bad 'link.point' references of joints, springs, loads and the trace
    (and joint names used twice, joints of a link to itself); returns the joint graph's edges
    (name, link 1, link 2, type) of the joints whose references are good."""
    names = set(p.links)
    pts = {GROUND: dict(p.ground), **{k: dict(v.points) for k, v in p.links.items()}}
    seen = set()

    def check_ref(ref, where):
        link, pt = _ref(ref)
        if link is None:
            out.append(f"{where}: {ref!r} is not 'link.point'")
            return None
        if link not in pts:
            out.append(f"{where}: link {link!r} is not defined (links: {', '.join(sorted(names)) or 'none'}, ground)")
            return None
        if pt not in pts[link]:
            out.append(f"{where}: link {link!r} has no point {pt!r} (points: {', '.join(sorted(pts[link])) or 'none'})")
            return None
        return link, pt

    edges = []
    for k, j in enumerate(p.joints):
        where = f"joints[{k}] ({j.name!r})"
        if j.name in seen:
            out.append(f"{where}: joint name used twice")
        seen.add(j.name)
        a = check_ref(j.at[0], where)
        b = check_ref(j.at[1], where)
        if a and b:
            if a[0] == b[0]:
                out.append(f"{where}: joins link {a[0]!r} to itself")
            else:
                edges.append((j.name, a[0], b[0], j.type))
    for k, s in enumerate(p.springs):
        for ref in s.between:
            check_ref(ref, f"springs[{k}]")
    for k, ld in enumerate(p.loads):
        if ld.point is not None:
            check_ref(ld.point, f"loads[{k}]")
        if ld.link is not None and ld.link not in names:
            out.append(f"loads[{k}]: link {ld.link!r} is not a moving link (links: {', '.join(sorted(names)) or 'none'}); "
                       f"a torque on the frame does no work")
    if p.trace is not None:
        check_ref(p.trace, "trace")
    return edges


def _zero_length_links(p) -> list:
    """Links whose revolute joint points all coincide."""
    out = []
    for name, L in p.links.items():
        used = set()
        for j in p.joints:
            if j.type != "revolute":
                continue
            for ref in j.at:
                lk, pt = _ref(ref)
                if lk == name and pt in L.points:
                    used.add(pt)
        if len(used) >= 2:
            xy = np.array([L.points[u] for u in sorted(used)])
            span = float(np.max(np.linalg.norm(xy[:, None, :] - xy[None, :, :], axis=-1)))
            if span <= 1e-9:
                out.append(f"links.{name}: zero length: its joint points {', '.join(sorted(used))} coincide")
    return out


def _input_joint_problems(p, jin) -> list:
    """The input joint: it exists, is revolute and joins the ground to a link."""
    if jin is None:
        return [f"input = {p.input!r}: no joint of that name (joints: {', '.join(j.name for j in p.joints)})"]
    if jin.type != "revolute":
        return [f"input = {p.input!r}: the input joint must be revolute (a crank driven through the gearbox)"]
    la, lb = _ref(jin.at[0])[0], _ref(jin.at[1])[0]
    if GROUND not in (la, lb):
        return [f"input = {p.input!r}: the input joint must connect the ground to the input link "
                f"(the motor sits on the frame); it joins {la!r} and {lb!r}"]
    return []


def _joint_graph(p, edges) -> dict:
    """{link: [(neighbour, joint name)]} of the joint graph (ground included)."""
    adj = {n: [] for n in list(p.links) + [GROUND]}
    for nm, a, b, _ in edges:
        adj[a].append((b, nm))
        adj[b].append((a, nm))
    return adj


def _reachable(adj, start, skip=None) -> set:
    """Links reachable from ``start`` through joints (breadth first), not through joint ``skip``."""
    reach, dq = {start}, deque([start])
    while dq:
        u = dq.popleft()
        for w, nm in adj[u]:
            if nm == skip:
                continue
            if w not in reach:
                reach.add(w)
                dq.append(w)
    return reach


# ============================================================================ spanning tree of the MJCF
class _Edge:
    """A tree joint oriented parent → child (link frames): revolute at p (parent) / c (child);
    prismatic: the child moves by d·u along the parent's axis u, relative angle phi."""

    __slots__ = ("k", "name", "kind", "parent", "child", "p", "c", "u", "phi", "line_first")

    def __init__(self, **kw):
        for k, v in kw.items():
            setattr(self, k, v)


class TreeMixin:
    """The spanning tree of the compiled description (:class:`.model._Compiled`): ``tree``
    (joint indices), ``closures`` (the other joints, sorted), ``edges`` (:class:`_Edge`, from the
    ground, breadth first) and ``parent_of`` {link: (parent, joint index)}."""

    def _tree(self):
        """Kruskal: input joint first, then prismatic joints, then revolute joints to the ground,
        then the other revolute joints (closures are then revolute, ``connect`` equalities, away
        from the frame where possible: a shallow tree).  Oriented from the ground by BFS."""
        p = self.p
        order = [self.jindex[nm] for nm in p.input_list]  # every input joint is a tree joint
        order += [k for k, j in enumerate(p.joints) if j.type == "prismatic" and k not in order]
        order += [k for k, j in enumerate(p.joints) if GROUND in (self.jlinks[k][0], self.jlinks[k][2])
                  and k not in order]
        order += [k for k, j in enumerate(p.joints) if k not in order]
        root = {n: n for n in self.links + [GROUND]}

        def find(x):
            while root[x] != x:
                root[x] = root[root[x]]
                x = root[x]
            return x

        tree, self.closures = [], []
        for k in order:
            l1, _, l2, _ = self.jlinks[k]
            a, b = find(l1), find(l2)
            if a != b:
                root[a] = b
                tree.append(k)
            else:
                self.closures.append(k)
        self.closures.sort()
        adj = {n: [] for n in self.links + [GROUND]}
        for k in tree:
            l1, _, l2, _ = self.jlinks[k]
            adj[l1].append((l2, k))
            adj[l2].append((l1, k))
        self.edges, self.parent_of = [], {GROUND: None}
        dq = deque([GROUND])
        while dq:
            u = dq.popleft()
            for w, k in sorted(adj[u], key=lambda t: order.index(t[1])):
                if w in self.parent_of:
                    continue
                self.parent_of[w] = (u, k)
                dq.append(w)
                self.edges.append(self._edge(k, u, w))
        self.tree = tree

    def _edge(self, k, parent, child):
        j = self.p.joints[k]
        l1, p1, l2, p2 = self.jlinks[k]
        first = parent == l1
        pp = self.pts[parent][p1 if first else p2]
        cc = self.pts[child][p2 if first else p1]
        if j.type == "revolute":
            return _Edge(k=k, name=j.name, kind="R", parent=parent, child=child, p=pp, c=cc, u=None, phi=0.0,
                         line_first=first)
        u = np.array(j.axis, float) / math.hypot(*j.axis)
        phi0 = float(j.angle)
        if first:  # parent owns the line
            return _Edge(k=k, name=j.name, kind="P", parent=parent, child=child, p=pp, c=cc, u=u, phi=phi0,
                         line_first=True)
        return _Edge(k=k, name=j.name, kind="P", parent=parent, child=child, p=pp, c=cc,
                     u=-(_rot2(-phi0) @ u), phi=-phi0, line_first=False)

    def cycle_of(self, k):
        """Joint names of the fundamental loop closed by joint k (tree path + k)."""
        l1, _, l2, _ = self.jlinks[k]

        def path(x):
            out = []
            while self.parent_of.get(x) is not None:
                u, e = self.parent_of[x]
                out.append((x, e))
                x = u
            return out

        pa, pb = path(l1), path(l2)
        ea, eb = [e for _, e in pa], [e for _, e in pb]
        common = set(ea) & set(eb)
        ks = [e for e in ea if e not in common] + [e for e in eb if e not in common] + [k]
        return [self.p.joints[e].name for e in sorted(set(ks))]
