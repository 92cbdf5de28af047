"""The 2006 paper's experiment (its section 5, figures 8-9) as a Kiji design session.

1. Drape: a rectangle of cotton is laid over the default body and falls on it under gravity.
2. Cut away what is not needed: two cuts across the cloth, from border to border beside the crown
   and stepping out around the head, and the piece between them (the cloth over the head) is removed:
   the front and back panels are now two pieces.
3. Sew: the front and back panels are sewn together over each shoulder (sew in 'seam' mode), leaving
   the opening for the head: one piece, a tabard, which settles on the shoulders.
4. Paint: letters are painted on the front (the paper painted JAPAN; here KIJI by default).
Then the garment is written as .glb (with its painted texture) and a picture as .png.

    kiji run python/kiji/examples/experiment.py --out out/garment.glb --picture out/garment.png
    python -m kiji.examples.experiment --spacing 0.04 --drape-seconds 1.5   # smaller and faster

Every size is a parameter (see --help): the cloth, its spacing, the simulated seconds, the head
opening, the text. The result is checked (one piece, resting on the body, letters in the texture)
and printed; run_experiment() returns the same figures for tests.
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


@dataclass
class Settings:
    width: float = 0.9            # m, across the shoulders (pattern x -> world x)
    length: float = 1.3           # m, front hem over the head to back hem (pattern y -> world -z)
    spacing: float = 0.04         # m between vertices
    material: str = "cotton"
    drape_seconds: float = 2.5
    settle_seconds: float = 2.0
    neck: float = 0.12            # m, half the width of the head opening
    neck_depth: float = 0.11      # m, half its length along the pattern (front to back)
    strip_rows: int = 2           # rows of faces cut away over the shoulders
    text: str = "KIJI"
    letter_height: float = 0.065  # m
    text_drop: float = 0.20       # m down the front from the neckline to the top of the text
    color: tuple = (0.98, 0.92, 0.25)
    brush: float = 0.008          # m, brush radius
    texture: int = 512            # texels a side
    frame_rate: float = 60.0
    substeps: int = 10
    out: Optional[str] = "out/garment.glb"
    picture: Optional[str] = "out/garment.png"
    picture_size: tuple = (1024, 768)
    verbose: bool = True


@dataclass
class Result:
    session: kiji.Session
    garment: kiji.Garment
    pieces: int
    measures: kiji.ClothMeasures
    painted_texels: int
    inside_fraction: float
    timings: dict = field(default_factory=dict)


def _say(settings: Settings, text: str) -> None:
    if settings.verbose:
        print(text, flush=True)


def _progress(settings: Settings, what: str):
    if not settings.verbose:
        return None
    last = [-1]
    live = sys.stdout.isatty()

    def report(fraction: float) -> None:
        tenth = int(fraction * 10)
        if tenth != last[0] and (live or fraction >= 1):
            last[0] = tenth
            print(f"\r  {what}: {100 * fraction:3.0f} %", end="\n" if fraction >= 1 else "", flush=True)

    return report


def _letter_strokes(text: str, height: float) -> list[np.ndarray]:
    """Polylines (metres, text-local: x right, y up, top-left at 0, 0) of the text, sampled every 5 mm."""
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
                n = max(1, int(np.ceil(np.linalg.norm(b - a) / 0.005)))
                dense += [a + (b - a) * (k / n) for k in range(1, n + 1)]
            strokes.append(np.array(dense))
        x0 += width + gap
    total = x0 - gap
    return [s - np.array([total / 2, 0]) for s in strokes]


def run_experiment(settings: Settings = Settings()) -> Result:
    st = settings
    timings = {}
    t0 = time.perf_counter()
    body = kiji.Body.default()
    s = kiji.Session(body=body, frame_rate=st.frame_rate)
    solver = s.solver_params
    solver.substeps = st.substeps
    s.solver_params = solver
    cloth = kiji.rectangle(st.width, st.length, spacing=st.spacing, material=kiji.Material(st.material),
                           name="garment")
    cloth.color = (0.75, 0.12, 0.15)
    g = s.add_garment(cloth)
    # The grid of the flat pattern: column and row of every vertex, kept by vertex id.
    flat = g.positions
    xs, ys = np.unique(np.round(flat[:, 0], 9)), np.unique(np.round(flat[:, 1], 9))
    nx, ny = len(xs), len(ys)
    grid = {}
    for vid, p in zip(g.vertex_ids, flat):
        grid[(int(np.argmin(abs(xs - p[0]))), int(np.argmin(abs(ys - p[1]))))] = int(vid)
    _say(st, f"kiji experiment: {g.vertex_count} vertices ({nx} x {ny}), {st.spacing * 100:g} cm apart, "
             f"on {body.name} ({body.height:.2f} m)")

    # 1. Drape.
    s.drape(seconds=st.drape_seconds, progress=_progress(st, "drape"))
    timings["drape"] = time.perf_counter() - t0

    # 2. Cut away what is not needed: the cloth over the head. Each cut runs from border to border
    #    along a row of the pattern beside the crown, stepping out around the head: a narrow strip
    #    over the shoulders (so the seams there close a small gap) and an opening for the head.
    s.simulating = False  # nothing falls while the scissors and the needle work
    centre = st.width / 2
    mid = ny // 2
    front, back = mid - st.strip_rows // 2, mid - st.strip_rows // 2 + st.strip_rows
    depth = max(st.strip_rows // 2 + 1, int(round(st.neck_depth / st.spacing)))
    neck_front, neck_back = mid - depth, mid + depth
    left = [c for c in range(nx) if xs[c] <= centre - st.neck]
    right = [c for c in range(nx) if xs[c] >= centre + st.neck]
    if len(left) < 2 or len(right) < 2:
        raise kiji.InputError("experiment: the head opening (neck) is wider than the cloth")
    if neck_front < 1 or neck_back > ny - 2:
        raise kiji.InputError("experiment: the cloth is too short for the head opening")
    cl, cr = left[-1], right[0]

    def around_head(row: int, neck_row: int) -> list:
        step = -1 if neck_row < row else 1
        path = [(c, row) for c in range(0, cl + 1)]
        path += [(cl, r) for r in range(row + step, neck_row + step, step)]
        path += [(c, neck_row) for c in range(cl + 1, cr + 1)]
        path += [(cr, r) for r in range(neck_row - step, row - step, -step)]
        path += [(c, row) for c in range(cr + 1, nx)]
        return path

    def points_of(cells) -> np.ndarray:
        at = {int(v): i for i, v in enumerate(g.vertex_ids)}
        pos = g.positions
        return np.array([pos[at[grid[cell]]] for cell in cells])

    # Where the shoulder borders are, before the cuts split their vertices (nothing moves meanwhile).
    front_shoulder = points_of([(c, front) for c in range(nx)])
    back_shoulder = points_of([(c, back) for c in range(nx)])
    crown = grid[(nx // 2, mid)]
    s.cut(points_of(around_head(front, neck_front)))
    s.cut(points_of(around_head(back, neck_back)))
    if g.piece_count != 3:
        raise kiji.Error(f"experiment: the two cuts made {g.piece_count} pieces, not 3")
    rows = {int(v): i for i, v in enumerate(g.vertex_ids)}
    g.remove_piece(int(np.nonzero((g.faces == rows[crown]).any(axis=1))[0][0]))
    _say(st, f"  cut away the cloth over the head: {g.piece_count} pieces, front and back")

    # 3. Sew the shoulders: trace the front's border (primary button), then the back's (secondary).
    for cols in (left, right[::-1]):
        a, b = front_shoulder[cols], back_shoulder[cols]
        s.sew(np.vstack([a, b]), buttons=[1] * len(a) + [2] * len(b), mode="seam")
    _say(st, f"  sewed the shoulders: {g.piece_count} piece(s), {len(g.border_loops())} border loops")
    if g.piece_count != 1:
        raise kiji.Error(f"experiment: after sewing the garment has {g.piece_count} pieces")

    # Let it settle on the shoulders, the head through the opening.
    s.simulating = True
    t1 = time.perf_counter()
    s.simulate(st.settle_seconds, progress=_progress(st, "settle"))
    timings["settle"] = time.perf_counter() - t1

    # 4. Paint the letters on the front, below the neckline, centred.
    s.simulating = False
    scale = g.pattern_scale
    top = ys[front] - st.text_drop
    positions, faces, uvs = g.positions, g.faces, g.uvs
    strokes = 0
    for line in _letter_strokes(st.text, st.letter_height):
        uv = (line + np.array([centre, top])) / scale
        points, normals = point_at_uv(g, uv, positions=positions, faces=faces, uvs=uvs)
        ok = ~np.isnan(points).any(axis=1)
        if ok.sum() < 2:
            continue
        # The pen just off the outer side of the cloth (the side facing away from the body's axis).
        outward = np.sign(((points[ok] - [0, 0, 0]) * normals[ok])[:, [0, 2]].sum(axis=1, keepdims=True))
        pen = points[ok] + 0.001 * outward * normals[ok]
        s.paint(pen, color=st.color, radius=st.brush, resolution=st.texture, touch_distance=0.01, hardness=0.9)
        strokes += 1
    s.simulating = True
    s.simulate(0.25)
    tex = g.texture
    painted = 0
    if tex is not None:
        painted = int((np.abs(tex[..., :3].astype(int) - np.array(st.color) * 255).max(axis=2) <= 2).sum())
    _say(st, f"  painted '{st.text}' in {strokes} strokes: {painted} texels")

    m = s.measure()
    inside = _inside_fraction(body, g.positions)
    timings["total"] = time.perf_counter() - t0
    if st.out:
        os.makedirs(os.path.dirname(os.path.abspath(st.out)), exist_ok=True)
        g.export(st.out)
    if st.picture:
        os.makedirs(os.path.dirname(os.path.abspath(st.picture)), exist_ok=True)
        box = np.vstack([body.bounds, g.bounds])
        box = np.array([box.min(axis=0), box.max(axis=0)])
        s.save_picture(st.picture, width=st.picture_size[0], height=st.picture_size[1],
                       camera=kiji.Camera.framing(box))
    _say(st, f"  {g.piece_count} piece, {m.contacts} vertices touching the body, deepest "
             f"{1000 * m.max_penetration:.1f} mm inside (cloth {1000 * g.material.thickness:.0f} mm thick), "
             f"max strain {100 * m.max_strain:.0f} %")
    _say(st, f"  {timings['total']:.1f} s in all (drape {timings['drape']:.1f} s, settle {timings['settle']:.1f} s)")
    if st.out or st.picture:
        _say(st, "wrote " + " and ".join(p for p in (st.out, st.picture) if p))
    return Result(s, g, g.piece_count, m, painted, inside, timings)


def _inside_fraction(body: kiji.Body, points: np.ndarray) -> float:
    """Fraction of cloth vertices inside the body's closed-ish surface, by the side of the nearest
    body vertex's area-weighted normal (rough but independent of the solver's own measure)."""
    bv, bt = body.vertices, body.triangles
    fn = np.cross(bv[bt[:, 1]] - bv[bt[:, 0]], bv[bt[:, 2]] - bv[bt[:, 0]])
    vn = np.zeros_like(bv)
    for k in range(3):
        np.add.at(vn, bt[:, k], fn)
    inside = 0
    for p in points:
        d = ((bv - p) ** 2).sum(axis=1)
        i = int(np.argmin(d))
        if d[i] < 0.03 ** 2 and np.dot(p - bv[i], vn[i]) < -1e-4 * np.linalg.norm(vn[i]):
            inside += 1
    return inside / max(1, len(points))


def main(argv: Optional[list[str]] = None) -> int:
    d = Settings()
    ap = argparse.ArgumentParser(prog="experiment", description=__doc__.split("\n\n")[0])
    ap.add_argument("--width", type=float, default=d.width, help="cloth width, m (default %(default)s)")
    ap.add_argument("--length", type=float, default=d.length, help="cloth length, m (default %(default)s)")
    ap.add_argument("--spacing", type=float, default=d.spacing, help="vertex spacing, m (default %(default)s)")
    ap.add_argument("--material", default=d.material, help="cotton, silk, denim, rubber or tissue")
    ap.add_argument("--drape-seconds", type=float, default=d.drape_seconds)
    ap.add_argument("--settle-seconds", type=float, default=d.settle_seconds)
    ap.add_argument("--neck", type=float, default=d.neck, help="half width of the head opening, m")
    ap.add_argument("--neck-depth", type=float, default=d.neck_depth, help="half length of the head opening, m")
    ap.add_argument("--text", default=d.text, help=f"letters to paint (of {''.join(sorted(FONT))} and space)")
    ap.add_argument("--texture", type=int, default=d.texture, help="texture size, texels a side")
    ap.add_argument("--substeps", type=int, default=d.substeps)
    ap.add_argument("--out", default=d.out, help="garment file, .glb or .obj (default %(default)s)")
    ap.add_argument("--picture", default=d.picture, help="PNG picture (default %(default)s)")
    ap.add_argument("--quiet", action="store_true")
    a = ap.parse_args(argv)
    settings = Settings(width=a.width, length=a.length, spacing=a.spacing, material=a.material,
                        drape_seconds=a.drape_seconds, settle_seconds=a.settle_seconds, neck=a.neck,
                        neck_depth=a.neck_depth, text=a.text,
                        texture=a.texture, substeps=a.substeps, out=a.out, picture=a.picture, verbose=not a.quiet)
    try:
        run_experiment(settings)
    except kiji.Error as e:
        print(f"experiment: {e}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
