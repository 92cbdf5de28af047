"""Composes docs/images' Kiji Studio pictures from the screenshots the Studio tests take.

Run the tests first (their windows are kept under build/tests/studio/tmp), then, from the
repository's root:

    xvfb-run -a -s "-screen 0 1600x1200x24" build/tests/studio/test_studio \
        the_papers_experiment_by_hand_with_real_x_events \
        a_closed_cut_drawn_with_real_x_events_cuts_out_an_opening_along_the_line
    .venv/bin/python scripts/studio_pictures.py
"""
import pathlib
import sys

import numpy as np

import kiji

ROOT = pathlib.Path(__file__).resolve().parent.parent
SHOTS = ROOT / "build" / "tests" / "studio" / "tmp"
CLEAR = (237, 237, 242)  # the viewport's background: where the view is in a window's picture
GAP = 6


def view_of(path: pathlib.Path, width: int = 880, height: int = 580) -> np.ndarray:
    """The middle of a window picture's viewport, halved (each pixel the mean of four)."""
    im = np.asarray(kiji.read_png(str(path)))
    background = np.all(im[..., :3] == CLEAR, axis=-1)
    cols, rows = np.nonzero(background.any(0))[0], np.nonzero(background.any(1))[0]
    cx, cy = (cols.min() + cols.max()) // 2, (rows.min() + rows.max()) // 2
    x0 = max(cols.min(), cx - width // 2)
    y0 = max(rows.min(), cy - height // 2)
    crop = im[y0:y0 + height, x0:x0 + width].astype(np.float32)
    h, w = crop.shape[0] // 2 * 2, crop.shape[1] // 2 * 2
    crop = crop[:h, :w]
    half = (crop[0::2, 0::2] + crop[1::2, 0::2] + crop[0::2, 1::2] + crop[1::2, 1::2]) / 4
    return half.round().astype(np.uint8)


def grid(panels: list, columns: int) -> np.ndarray:
    h, w = panels[0].shape[:2]
    rows = (len(panels) + columns - 1) // columns
    out = np.full((rows * h + (rows - 1) * GAP, columns * w + (columns - 1) * GAP, 4), 255, np.uint8)
    for i, p in enumerate(panels):
        r, c = divmod(i, columns)
        out[r * (h + GAP):r * (h + GAP) + p.shape[0], c * (w + GAP):c * (w + GAP) + p.shape[1]] = p
    return out


def main() -> int:
    stages = ["1_draped", "2_cut_closing", "4_fallen", "5_seam_picked", "7_sewn", "8_painted"]
    wanted = [SHOTS / "experiment" / f"{s}.png" for s in stages] + [SHOTS / "cut_closing.png", SHOTS / "cut_out.png"]
    missing = [str(p) for p in wanted if not p.exists()]
    if missing:
        print("missing (run the Studio tests named in this script's docstring first):\n  " + "\n  ".join(missing),
              file=sys.stderr)
        return 1
    out = ROOT / "docs" / "images"
    kiji.write_png(grid([view_of(p) for p in wanted[:6]], 3), str(out / "studio_experiment" / "stages.png"))
    kiji.write_png(grid([view_of(p) for p in wanted[6:]], 2), str(out / "studio_cut_closed_loop.png"))
    print("wrote", out / "studio_experiment" / "stages.png", "and", out / "studio_cut_closed_loop.png")
    return 0


if __name__ == "__main__":
    sys.exit(main())
