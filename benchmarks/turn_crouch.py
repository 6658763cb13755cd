"""The self-rendered start-walk-turn-crouch-walk sequence (:func:`ipf_jax.viz.synthetic.walk_turn_crouch`),
tracked and scored like the visible renders (``accuracy.py``'s table).

    python benchmarks/turn_crouch.py --out DIR [--cameras 4] [--python-path TREE] [-- TRACK ARGS]

Self-rendered: the masks are drawn with the tracker's own capsule model through a ring of virtual
cameras (320x240), so the figures show whether the tracker keeps or recovers the track through a
turn and a deep crouch, not how well the model fits real people.
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from accuracy import markdown, run_set

from ipf_jax.body import default_shape
from ipf_jax.viz import synthetic as syn

NAME = "self_walk_turn_crouch"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", required=True, type=Path)
    ap.add_argument("--cameras", type=int, default=4)
    ap.add_argument("--python-path", help="run the ipf_jax found in this folder (another revision)")
    ap.add_argument("track_args", nargs="*")
    args = ap.parse_args(argv)
    root = args.out / "data"
    data = root / NAME
    if not (data / "ground_truth.csv").is_file():
        shape = default_shape(1.75)
        q = syn.walk_turn_crouch(shape=shape)
        cams = syn.ring_cameras(args.cameras, width=320, height=240, focal_px=300)
        syn.write_dataset(data, cams, syn.render_masks(q, shape, cams))
        syn.write_truth(data / "ground_truth.csv", syn.joints_of(q, shape))
    row = run_set(NAME, root, args.out, args.track_args, args.python_path)
    (args.out / "accuracy.json").write_text(json.dumps({"track_args": args.track_args, "rows": [row]},
                                                       indent=1))
    print(markdown([row]))
    return 0


if __name__ == "__main__":
    sys.exit(main())
