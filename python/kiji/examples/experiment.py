"""The 2006 paper's experiment (its section 5, figures 8-9): a tunic made in a Kiji design session.

1. Drape: a rectangle of cotton is laid over the default body and falls on it under gravity.
2. Cut: an opening for the head is cut around the crown, set a little towards the front as a tunic's
   pattern sets it, and the cloth over the head is removed; the cloth falls through the opening onto
   the shoulders, a front panel and a back panel, held flat by their hems' corners and the front's
   neckline (six pinches) as they fall.
3. Sew: the front's sides are sewn to the back's, from the hem up to the armholes, pair of border
   vertices by pair as a tailor sews a seam, the first pairs carried together by hand (pinch): one
   piece, a tunic with a neck opening and two armholes.
4. Paint: letters on the chest (the paper painted JAPAN; here KIJI by default).

It writes the garment (.glb, with its painted texture), a picture of it from the front, and the four
stages side by side as the paper's figure 8 shows them, and prints the checks a designer makes.

    kiji run python/kiji/examples/experiment.py --out out/garment.glb --picture out/garment.png
    python -m kiji.examples.experiment --spacing 0.02       # a coarser cloth, in a few seconds

Every size is a parameter (see --help). run_experiment() returns the garment and its checks.
"""
from __future__ import annotations

import argparse
import os
import sys
import time
from dataclasses import dataclass, field
from typing import Optional

import numpy as np

import kiji
from kiji.geometry import point_at_uv

# A stroke font in a unit box (x right, y up): each letter a list of polylines.
FONT = {
    "A": [[(0, 0), (0.5, 1), (1, 0)], [(0.25, 0.5), (0.75, 0.5)]],
    "I": [[(0.5, 0), (0.5, 1)], [(0.2, 1), (0.8, 1)], [(0.2, 0), (0.8, 0)]],
    "J": [[(0.2, 1), (0.9, 1)], [(0.7, 1), (0.7, 0.25), (0.55, 0), (0.3, 0), (0.1, 0.2)]],
    "K": [[(0, 0), (0, 1)], [(0.9, 1), (0, 0.4)], [(0.3, 0.6), (0.9, 0)]],
    "N": [[(0, 0), (0, 1), (0.9, 0), (0.9, 1)]],
    "P": [[(0, 0), (0, 1), (0.7, 1), (0.9, 0.85), (0.9, 0.65), (0.7, 0.5), (0, 0.5)]],
}

STAGES = ("drape", "cut", "sew", "paint")


@dataclass
class Settings:
    width: float = 0.6            # m, across the shoulders (pattern x -> world x)
    length: float = 1.44          # m, front hem over the shoulders to back hem (pattern y -> world -z)
    spacing: float = 0.012        # m between vertices
    material: str = "cotton"
    drape_seconds: float = 2.8    # the cloth falls onto the head (17 of 18 lengths 1.8-3.5 s: docs/benchmarks.md)
    fall_seconds: float = 1.2     # after the head opening is cut, it falls onto the shoulders
    settle_seconds: float = 0.8   # after sewing
    neck: float = 0.12            # m, half the width of the head opening (pattern x)
    neck_depth: float = 0.11      # m, half its length (pattern y, front to back)
    neck_forward: float = 0.025   # m the head opening is set towards the front hem from the pattern's middle
    armhole: float = 0.30         # m of the pattern from the shoulder line down to the armhole's end
    seam_start: float = 0.33      # where up the side seam the sewing starts, from the hem (0) to the armhole (1)
    text: str = "KIJI"
    letter_height: float = 0.06   # m
    text_drop: float = 0.07       # m down the front from the head opening to the top of the text
    color: tuple = (0.98, 0.92, 0.25)
    brush: float = 0.006          # m, brush radius
    texture: int = 1024           # texels a side
    substeps: int = 40            # a step's substeps: the drape's, for cloth landing on the body
    out: Optional[str] = "out/garment.glb"
    picture: Optional[str] = "out/garment.png"   # the tunic from the front
    stages: Optional[str] = "out/stages.png"     # the four stages side by side
    picture_size: tuple = (1024, 1024)
    verbose: bool = True


@dataclass
class Checks:
    """What a designer checks on the finished garment."""
    pieces: int
    border_loops: dict            # "hem", "neck", "left armhole", "right armhole": vertices in each
    contacts: int                 # cloth vertices touching the body
    max_penetration: float        # m, deepest cloth vertex inside the body (0: none)
    inside_fraction: float        # share of cloth vertices inside the body, by an independent test
    max_strain: float             # largest edge stretch, as a fraction of its rest length
    mean_strain: float
    painted_texels: int
    painted_seen: float           # share of the painted texels the front camera sees
    hem_range: float              # m between the hem's highest and lowest point
    asymmetry: float              # m, mean distance from the cloth's mirror image to the cloth


@dataclass
class Result:
    session: kiji.Session
    garment: kiji.Garment
    checks: Checks
    timings: dict = field(default_factory=dict)


def _say(settings: Settings, text: str) -> None:
    if settings.verbose:
        print(text, flush=True)


def _letter_strokes(text: str, height: float) -> list[np.ndarray]:
    """Polylines (metres, text-local: x right, y up, top-centre at 0, 0) of the text, sampled every 3 mm."""
    strokes = []
    width = 0.75 * height
    gap = 0.35 * height
    x0 = 0.0
    for ch in text.upper():
        if ch == " ":
            x0 += width + gap
            continue
        if ch not in FONT:
            raise kiji.InputError(f"experiment: no letter '{ch}' in the stroke font; use {''.join(sorted(FONT))}")
        for line in FONT[ch]:
            pts = np.array([(x0 + width * x, height * (y - 1)) for x, y in line])
            dense = [pts[0]]
            for a, b in zip(pts[:-1], pts[1:]):
                n = max(1, int(np.ceil(np.linalg.norm(b - a) / 0.003)))
                dense += [a + (b - a) * (k / n) for k in range(1, n + 1)]
            strokes.append(np.array(dense))
        x0 += width + gap
    total = x0 - gap
    return [s - np.array([total / 2, 0]) for s in strokes]


class _Pattern:
    """The flat pattern's grid: the vertex id at each column and row, kept through the edits."""

    def __init__(self, garment: kiji.Garment):
        flat = garment.positions
        self.xs = np.unique(np.round(flat[:, 0], 9))
        self.ys = np.unique(np.round(flat[:, 1], 9))
        self.id = {}
        for vid, p in zip(garment.vertex_ids, flat):
            self.id[(int(np.argmin(abs(self.xs - p[0]))), int(np.argmin(abs(self.ys - p[1]))))] = int(vid)
        self.nx, self.ny = len(self.xs), len(self.ys)


def _positions_of(garment: kiji.Garment, ids) -> np.ndarray:
    row = {int(v): i for i, v in enumerate(garment.vertex_ids)}
    missing = [v for v in ids if v not in row]
    if missing:
        raise kiji.Error(f"experiment: vertices {missing[:5]} are gone from the garment")
    return garment.positions[[row[v] for v in ids]]


def _front_camera(body: kiji.Body, size: tuple) -> kiji.Camera:
    """The front camera: the body from its knees up, from +Z (the way the body faces)."""
    lo, hi = body.bounds
    box = np.array([[lo[0], lo[1] + 0.3 * (hi[1] - lo[1]), lo[2]], [hi[0], hi[1] + 0.02, hi[2]]])
    camera = kiji.Camera.framing(box)
    # The camera fits the box's larger half-size to the vertical view; a picture narrower than tall
    # shows less across, so the camera steps back until the box's width fits too.
    half_w, half_h = 0.5 * (box[1, 0] - box[0, 0]), 0.5 * (box[1, 1] - box[0, 1])
    aspect = size[0] / size[1]
    wider = half_w / (aspect * max(half_w, half_h))
    if wider > 1:
        camera.eye = camera.target + (camera.eye - camera.target) * wider
    return camera


def _hands(s: kiji.Session, starts, goals, frames: int, **pinch) -> None:
    """Pinches the cloth at each of `starts`, a hand each (users 0, 1, ...), moves the hands a frame at a
    time to goals(k) for k = 1 ... frames, and lets go at the last. The first hand's event steps the
    simulation; the others share its step."""
    frame = 1.0 / s.frame_rate
    for user, p in enumerate(starts):
        s.begin("pinch", kiji.ToolEvent("begin", p, time=s.time), user=user, **pinch)
    for k in range(1, frames + 1):
        t = s.time + frame
        for user, goal in enumerate(goals(k)):
            if k == frames:
                s.end(kiji.ToolEvent("end", goal, time=t), user=user)
            else:
                s.update(kiji.ToolEvent("move", goal, time=t), user=user)


def _fall_held_apart(s: kiji.Session, g: kiji.Garment, pattern: "_Pattern", st: Settings) -> None:
    """The panels fall onto the shoulders with the corners of each hem held apart, as a tailor holds a
    panel by its corners so that it hangs flat: a fold the drape left in a panel is drawn out before
    the panel lands, where it would otherwise be sewn into the side seam. Four hands (pinches) carry
    the corners out to the cloth's width over the first quarter of the fall; they go down with the
    cloth (each pulls a little below its corner, never holding it up) and let go for the last
    quarter. Two more draw the front's neckline apart by its ends, a few millimetres a frame: a fold
    the drape left over the head can run from the neckline down the chest, short of the hem, where
    the painted letters go."""
    nx, ny = pattern.nx, pattern.ny
    corners = [pattern.id[(column, row)] for row in (0, ny - 1) for column in (0, nx - 1)]
    neck = np.array(min(g.border_loops(), key=len))  # the head opening, the cloth's outline being longer
    positions = g.positions
    front = neck[positions[neck, 2] > body_axis_z(s.body)]
    ends = []
    if len(front) >= 2:
        ids = g.vertex_ids
        ends = [int(ids[front[np.argmin(positions[front, 0])]]), int(ids[front[np.argmax(positions[front, 0])]])]
    starts = _positions_of(g, corners + ends)
    across = 0.95 * 0.5 * st.width * np.array([-1.0, 1.0, -1.0, 1.0])
    steps = max(4, round(st.fall_seconds * s.frame_rate))

    def goals(k: int) -> list:
        out = min(1.0, k / (steps // 4))
        now = _positions_of(g, corners + ends)
        return ([np.array([start[0] + out * (x - start[0]), p[1] - 0.004, p[2]])
                 for start, x, p in zip(starts[:4], across, now[:4])] +
                [p + np.array([side * 0.003, 0.0, 0.0]) for p, side in zip(now[4:], (-1.0, 1.0))])

    _hands(s, starts, goals, steps - steps // 4)
    s.simulate((steps // 4) / s.frame_rate)


def _carry(s: kiji.Session, g: kiji.Garment, pairs: list, spacing: float) -> None:
    """Carries the `front` vertex of each (front, back, outward) pair round the outside of the cloth to
    beside its `back` over 0.4 s, each with a hand of its own (a pinch of that vertex alone), all at
    once, the cloth following. A hand sews nothing on its way: a needle carried this far met the
    crumpled border it pulled along and tacked it to itself. Both sides at once, so that neither
    seam pulls the garment its way before the other."""
    paths = []
    for front, back, outward in pairs:
        a, b = _positions_of(g, [front, back])
        detour = 2.5 * spacing * outward
        legs = [(a, a + detour, 6), (a + detour, b + detour, 18)]
        paths.append(np.vstack([a] + [p + (q - p) * (np.arange(1, n + 1)[:, None] / n) for p, q, n in legs]))
    _hands(s, [path[0] for path in paths], lambda k: [path[k] for path in paths], len(paths[0]) - 1,
           grab_radius=0.0, stiffness=200.0)


def _join(s: kiji.Session, g: kiji.Garment, front: int, back: int, spacing: float) -> None:
    """Sews border vertex `front` to `back` with the needle (sew in 'pinch' mode), the cloth held
    still, so that `back` is where the needle ends: the first pair of a seam is tacked, a later one,
    next to the seam's end, merged. Raises kiji.Error if the pair is not joined."""
    rows = {int(v): i for i, v in enumerate(g.vertex_ids)}
    tacks = len(g.tacks)
    a, b = _positions_of(g, [front, back])
    s.simulating = False
    try:
        s.sew(np.vstack([a, b]), mode="pinch", distance=0.5 * spacing)
    finally:
        s.simulating = True
    if front in set(int(v) for v in g.vertex_ids):
        if not (len(g.tacks) > tacks and {rows[front], rows[back]} == set(g.tacks[-1].tolist())):
            raise kiji.Error(f"experiment: the side seam did not close between border vertices {front} and "
                             f"{back} ({np.linalg.norm(b - a) * 100:.1f} cm apart)")


def _last_seam_row(st: Settings) -> int:
    """The pattern row where the side seams end and the armholes begin."""
    return int(np.floor((st.length / 2 - st.armhole) / st.spacing + 1e-9))


def _check(st: Settings) -> None:
    """Settings that cannot make a tunic are refused before anything is simulated, saying why."""
    if not (st.spacing > 0 and st.width > 0 and st.length > 0):
        raise kiji.InputError("experiment: the cloth's width, length and spacing must be positive")
    if st.width / st.spacing * st.length / st.spacing > 2e6:
        raise kiji.InputError("experiment: the cloth would have over 2 million vertices: give a larger spacing")
    if not (0 < st.neck < st.width / 2 - 2 * st.spacing and 0 < st.neck_depth < st.length / 2 - 2 * st.spacing):
        raise kiji.InputError("experiment: the head opening does not fit the cloth: make neck and neck_depth "
                              "smaller, or the cloth larger")
    if not 0 < st.armhole < st.length / 2 or _last_seam_row(st) < 2:
        raise kiji.InputError("experiment: no side is left to sew below the armholes: make armhole smaller "
                              "than half the cloth's length")
    if not abs(st.neck_forward) < st.length / 2 - st.neck_depth - 2 * st.spacing:
        raise kiji.InputError("experiment: neck_forward sets the head opening off the cloth: keep it within "
                              "half the cloth's length less neck_depth")
    if st.armhole <= st.neck_depth + abs(st.neck_forward):
        raise kiji.InputError("experiment: the armholes would reach above the head opening: make armhole "
                              "larger than neck_depth and neck_forward together")
    if not 0 <= st.seam_start <= 1:
        raise kiji.InputError("experiment: seam_start is a share of the side seam, from 0 (hem) to 1 (armhole)")
    _letter_strokes(st.text, st.letter_height)  # every letter in the font


def run_experiment(settings: Settings = Settings()) -> Result:
    st = settings
    _check(st)
    timings = {}
    t0 = time.perf_counter()
    body = kiji.Body.default()
    s = kiji.Session(body=body)
    solver = s.solver_params
    solver.substeps = st.substeps
    s.solver_params = solver
    cloth = kiji.rectangle(st.width, st.length, spacing=st.spacing, material=kiji.Material(st.material),
                           name="tunic")
    cloth.color = (0.72, 0.13, 0.16)
    g = s.add_garment(cloth)
    pattern = _Pattern(g)
    nx, ny = pattern.nx, pattern.ny
    _say(st, f"kiji experiment: a tunic from {g.vertex_count} vertices of {st.material} ({nx} x {ny}, "
             f"{st.spacing * 100:g} cm apart) on {body.name} ({body.height:.2f} m)")
    camera = _front_camera(body, st.picture_size)
    stage_size = (400, 400)
    stage_camera = _front_camera(body, stage_size)
    stage_pictures = []

    def stage_done(name: str) -> None:
        timings[name] = time.perf_counter() - t0 - sum(timings.values())
        if st.stages:
            stage_pictures.append(s.render(camera=stage_camera, width=stage_size[0], height=stage_size[1]))

    # 1. Drape.
    # The tunic falls itself, step by step: its checks hold at the drape lengths measured so
    # (docs/benchmarks.md). Draped coarse first instead, at 2.8 s, its hem came out 11.7 cm out of
    # level and its largest strain 11.6 %, in 1.8 s against 5.5.
    s.drape(seconds=st.drape_seconds, coarse=False)
    _say(st, f"  1. draped: {st.drape_seconds:g} s on the body")
    stage_done("drape")

    # 2. Cut the head opening: one stroke around an ellipse on the crown of the pattern, back to where
    #    it began (the knife cuts out what a closed line encloses), and take away the cloth over the
    #    head. The knife goes straight in the pattern between the stroke's points: a walk over the
    #    surface stops where a fold of the draped crown turns it back, as at a crease on purpose.
    s.simulating = False  # nothing falls while the scissors work
    # The opening is set a little forward of the middle, as a tunic's pattern sets it: the front panel
    # falls over the chest and hangs lower at its sides than the back unless it is that much shorter,
    # and the side seams then lift the front's sides into a fold across the hips.
    centre_u, centre_v = st.width / 2, st.length / 2 - st.neck_forward
    scale = g.pattern_scale

    def around_head(start: float, stop: float) -> np.ndarray:
        angles = np.linspace(start, stop, max(16, int(np.pi * st.neck / st.spacing * 2)))
        uv = np.c_[centre_u + st.neck * np.cos(angles), centre_v + st.neck_depth * np.sin(angles)] / scale
        points, _ = point_at_uv(g, uv)
        return points[~np.isnan(points).any(axis=1)]

    crown = pattern.id[(nx // 2, ny // 2)]
    s.cut(around_head(0, 2 * np.pi), follow="pattern")
    if g.piece_count != 2:
        raise kiji.Error(f"experiment: the cut around the head made {g.piece_count} pieces, not 2")
    rows = {int(v): i for i, v in enumerate(g.vertex_ids)}
    g.remove_piece(int(np.nonzero((g.faces == rows[crown]).any(axis=1))[0][0]))
    s.simulating = True
    _fall_held_apart(s, g, pattern, st)
    _say(st, f"  2. cut the head opening and took away the cloth over the head: it fell onto the shoulders")
    stage_done("cut")

    # 3. Sew the sides, front border to back border, from the hem up to the armholes. A pair a third
    #    of the way up each side is carried together first, slowly, by two hands, and tacked; every
    #    next pair, up to the armhole and then down to the hem, is a border vertex or two apart and is
    #    joined in one step: the seam closes behind the needle as a zip does.
    last_row = _last_seam_row(st)
    start_row = round(st.seam_start * last_row)
    order = list(range(start_row, last_row + 1)) + list(range(start_row - 1, -1, -1))
    for row in order:
        pairs = [(pattern.id[(column, row)], pattern.id[(column, ny - 1 - row)], np.array([outward, 0.0, 0.0]))
                 for column, outward in ((0, -1.0), (nx - 1, 1.0))]
        # The first pairs, and any later pair the cloth has not drawn within two and a half spacings
        # (joined where it is, its vertex would jump that far and fold the seam), are carried first.
        far = [p for p in pairs if row == start_row or
               np.linalg.norm(np.subtract(*_positions_of(g, p[:2]))) > 2.5 * st.spacing]
        if far:
            _carry(s, g, far, st.spacing)
        for front, back, _ in pairs:
            _join(s, g, front, back, st.spacing)
        s.step(1)  # the seam draws the next pair together
    s.simulate(st.settle_seconds)
    loops = g.border_loops()
    _say(st, f"  3. sewed the sides from the hem up to the armholes: {g.piece_count} piece, "
             f"{len(loops)} border loops")
    if g.piece_count != 1:
        raise kiji.Error(f"experiment: after sewing the garment is {g.piece_count} pieces, not one")
    stage_done("sew")

    # 4. Paint the letters on the chest below the head opening, centred on the body as the designer
    #    sees it from the front: the sewn tunic may hang turned a little about the body (the panels
    #    twist by a few centimetres as they fall onto the shoulders), so the text is moved along the
    #    cloth until its middle is on the body's midline.
    s.simulating = False
    top = centre_v - st.neck_depth - st.text_drop
    positions, faces, uvs = g.positions, g.faces, g.uvs
    lines = _letter_strokes(st.text, st.letter_height)
    across = centre_u
    for _ in range(3):
        uv = np.vstack(lines) + np.array([across, top])
        points, _ = point_at_uv(g, uv / scale, positions=positions, faces=faces, uvs=uvs)
        points = points[~np.isnan(points).any(axis=1)]
        if not len(points):
            break
        across -= points[:, 0].mean()  # pattern x runs with world x across the front
    strokes = 0
    for line in lines:
        uv = (line + np.array([across, top])) / scale
        points, normals = point_at_uv(g, uv, positions=positions, faces=faces, uvs=uvs)
        ok = ~np.isnan(points).any(axis=1)
        if ok.sum() < 2:
            continue
        # The pen just off the outer side of the cloth, the side facing away from the body's axis.
        axis = np.array([0.0, 0.0, body_axis_z(body)])
        outward = np.sign((((points[ok] - axis) * normals[ok])[:, [0, 2]]).sum(axis=1, keepdims=True))
        pen = points[ok] + 0.001 * outward * normals[ok]
        s.paint(pen, color=st.color, radius=st.brush, resolution=st.texture, touch_distance=0.01, hardness=0.9)
        strokes += 1
    s.simulating = True
    s.simulate(0.2)
    _say(st, f"  4. painted '{st.text}' on the chest in {strokes} strokes")
    stage_done("paint")
    timings["total"] = time.perf_counter() - t0

    checks = check_garment(s, g, st, camera)
    _report(st, checks, timings)
    if st.out:
        os.makedirs(os.path.dirname(os.path.abspath(st.out)), exist_ok=True)
        g.export(st.out)
    if st.picture:
        os.makedirs(os.path.dirname(os.path.abspath(st.picture)), exist_ok=True)
        s.save_picture(st.picture, width=st.picture_size[0], height=st.picture_size[1], camera=camera)
    if st.stages and stage_pictures:
        os.makedirs(os.path.dirname(os.path.abspath(st.stages)), exist_ok=True)
        kiji.write_png(np.concatenate(stage_pictures, axis=1), st.stages)
    written = [p for p in (st.out, st.picture, st.stages) if p]
    if written:
        _say(st, "wrote " + ", ".join(written))
    return Result(s, g, checks, timings)


def body_axis_z(body: kiji.Body) -> float:
    """The z of the body's vertical axis through its trunk (the middle of its top quarter)."""
    v = body.vertices
    lo, hi = body.bounds
    top = v[v[:, 1] >= hi[1] - 0.25 * (hi[1] - lo[1])]
    return 0.5 * (top[:, 2].min() + top[:, 2].max())


def painted_mask(garment: kiji.Garment, color) -> np.ndarray:
    """(H, W) bool: the texels of the garment's texture that carry the paint's colour."""
    tex = garment.texture
    if tex is None:
        return np.zeros((0, 0), bool)
    return np.abs(tex[..., :3].astype(int) - np.round(np.array(color) * 255)).max(axis=2) <= 2


def check_garment(s: kiji.Session, g: kiji.Garment, st: Settings, camera: kiji.Camera) -> Checks:
    body = s.body
    m = s.measure()
    positions = g.positions
    # Border loops, named by where they are: the lowest is the hem, the highest the neck opening,
    # the others the armholes, left (-x) and right (+x).
    loops = [positions[np.array(loop)] for loop in g.border_loops()]
    named = {}
    if loops:
        by_height = sorted(range(len(loops)), key=lambda i: loops[i][:, 1].mean())
        named["hem"] = by_height[0]
        if len(loops) > 1:
            named["neck"] = by_height[-1]
        for k, i in enumerate(by_height[1:-1]):
            side = "left armhole" if loops[i][:, 0].mean() < 0 else "right armhole"
            named[side if side not in named else f"{side} {k}"] = i
    border_loops = {name: len(loops[i]) for name, i in named.items()}
    hem = loops[named["hem"]] if loops else np.zeros((1, 3))
    # Painted texels, and which of them the front camera sees.
    mask = painted_mask(g, st.color)
    painted = int(mask.sum())
    seen = 0.0
    if painted:
        rows, cols = np.nonzero(mask)
        pick = np.random.default_rng(1).choice(painted, size=min(painted, 1500), replace=False)
        h, w = mask.shape
        uv = np.c_[(cols[pick] + 0.5) / w, (rows[pick] + 0.5) / h]
        points, _ = point_at_uv(g, uv, positions=positions)
        points = points[~np.isnan(points).any(axis=1)]
        if len(points):
            visible = kiji.visible_points(points, [g], body, camera=camera, width=st.picture_size[0],
                                          height=st.picture_size[1], tolerance=0.003)
            seen = float(visible.mean())
    return Checks(pieces=g.piece_count, border_loops=border_loops, contacts=m.contacts,
                  max_penetration=m.max_penetration, inside_fraction=inside_fraction(body, positions),
                  max_strain=m.max_strain, mean_strain=m.mean_strain, painted_texels=painted,
                  painted_seen=seen, hem_range=float(np.ptp(hem[:, 1])),
                  asymmetry=mirror_distance(positions))


def _bands(points: np.ndarray, size: int = 256):
    """The points in bands of `size` by height: each band's indices, lowest band first."""
    order = np.argsort(points[:, 1], kind="stable")
    for start in range(0, len(order), size):
        yield order[start:start + size]


def mirror_distance(points: np.ndarray, reach: float = 0.05) -> float:
    """Mean distance from each point's mirror image across x = 0 to the nearest point (at most
    `reach`): 0 for a garment symmetric left to right."""
    mirrored = points * np.array([-1.0, 1.0, 1.0])
    best = np.full(len(points), reach)
    for band in _bands(mirrored):
        lo, hi = mirrored[band, 1].min() - reach, mirrored[band, 1].max() + reach
        near = points[(points[:, 1] >= lo) & (points[:, 1] <= hi)]
        d = ((mirrored[band, None, :] - near[None, :, :]) ** 2).sum(axis=2)
        best[band] = np.minimum(np.sqrt(d.min(axis=1)), reach)
    return float(best.mean())


def inside_fraction(body: kiji.Body, points: np.ndarray, reach: float = 0.03) -> float:
    """Share of cloth vertices inside the body, by the side of the nearest body vertex's
    area-weighted normal (within `reach`): a test independent of the solver's own measure."""
    bv, bt = body.vertices, body.triangles
    fn = np.cross(bv[bt[:, 1]] - bv[bt[:, 0]], bv[bt[:, 2]] - bv[bt[:, 0]])
    vn = np.zeros_like(bv)
    for k in range(3):
        np.add.at(vn, bt[:, k], fn)
    inside = 0
    for band in _bands(points):
        chunk = points[band]
        lo, hi = chunk[:, 1].min() - reach, chunk[:, 1].max() + reach
        near = np.nonzero((bv[:, 1] >= lo) & (bv[:, 1] <= hi))[0]
        if not len(near):
            continue
        d = ((chunk[:, None, :] - bv[None, near, :]) ** 2).sum(axis=2)
        j = d.argmin(axis=1)
        i = near[j]
        close = d[np.arange(len(chunk)), j] < reach ** 2
        behind = ((chunk - bv[i]) * vn[i]).sum(axis=1) < -1e-4 * np.linalg.norm(vn[i], axis=1)
        inside += int((close & behind).sum())
    return inside / max(1, len(points))


def _report(st: Settings, c: Checks, timings: dict) -> None:
    loops = ", ".join(f"{name} ({n})" for name, n in c.border_loops.items())
    _say(st, f"checks: {c.pieces} piece; {len(c.border_loops)} border loops: {loops}")
    _say(st, f"        {c.contacts} vertices touching the body; deepest {1000 * c.max_penetration:.1f} mm inside, "
             f"{100 * c.inside_fraction:.1f} % of the cloth inside")
    _say(st, f"        largest edge strain {100 * c.max_strain:.1f} % (mean {100 * c.mean_strain:.2f} %)")
    _say(st, f"        hem level within {100 * c.hem_range:.1f} cm; left and right mirror each other within "
             f"{100 * c.asymmetry:.1f} cm on average")
    _say(st, f"        {c.painted_texels} painted texels, {100 * c.painted_seen:.0f} % of them seen from the front")
    stages = ", ".join(f"{name} {timings[name]:.1f} s" for name in STAGES if name in timings)
    _say(st, f"        {timings['total']:.1f} s in all ({stages})")


def main(argv: Optional[list[str]] = None) -> int:
    d = Settings()
    ap = argparse.ArgumentParser(prog="experiment", description=__doc__.split("\n\n")[0])
    ap.add_argument("--width", type=float, default=d.width, help="cloth width, m (default %(default)s)")
    ap.add_argument("--length", type=float, default=d.length, help="cloth length, m (default %(default)s)")
    ap.add_argument("--spacing", type=float, default=d.spacing, help="vertex spacing, m (default %(default)s)")
    ap.add_argument("--material", default=d.material, help="cotton, silk, denim, rubber or tissue")
    ap.add_argument("--drape-seconds", type=float, default=d.drape_seconds)
    ap.add_argument("--fall-seconds", type=float, default=d.fall_seconds)
    ap.add_argument("--settle-seconds", type=float, default=d.settle_seconds)
    ap.add_argument("--neck", type=float, default=d.neck, help="half width of the head opening, m")
    ap.add_argument("--neck-depth", type=float, default=d.neck_depth, help="half length of the head opening, m")
    ap.add_argument("--neck-forward", type=float, default=d.neck_forward,
                    help="how far the head opening is set towards the front hem, m")
    ap.add_argument("--armhole", type=float, default=d.armhole,
                    help="pattern length from the shoulder line down to the end of the armhole, m")
    ap.add_argument("--text", default=d.text, help=f"letters to paint (of {''.join(sorted(FONT))} and space)")
    ap.add_argument("--texture", type=int, default=d.texture, help="texture size, texels a side")
    ap.add_argument("--substeps", type=int, default=d.substeps)
    ap.add_argument("--out", default=d.out, help="garment file, .glb or .obj (default %(default)s)")
    ap.add_argument("--picture", default=d.picture, help="PNG of the tunic from the front (default %(default)s)")
    ap.add_argument("--stages", default=d.stages, help="PNG of the four stages side by side (default %(default)s)")
    ap.add_argument("--quiet", action="store_true")
    a = ap.parse_args(argv)
    settings = Settings(width=a.width, length=a.length, spacing=a.spacing, material=a.material,
                        drape_seconds=a.drape_seconds, fall_seconds=a.fall_seconds,
                        settle_seconds=a.settle_seconds, neck=a.neck, neck_depth=a.neck_depth,
                        neck_forward=a.neck_forward,
                        armhole=a.armhole, text=a.text, texture=a.texture, substeps=a.substeps, out=a.out,
                        picture=a.picture, stages=a.stages, verbose=not a.quiet)
    try:
        run_experiment(settings)
    except kiji.Error as e:
        print(e if str(e).startswith("experiment:") else f"experiment: {e}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
