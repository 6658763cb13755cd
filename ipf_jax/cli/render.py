"""``ipf-jax render RUN_DIR --out FILE|DIR``: overlays of a tracked run (:func:`ipf_jax.viz.render.render_run`)."""
from __future__ import annotations

import argparse

from ..viz.render import MAX_SIDE, MIN_SIDE, render_run
from .options import add_common, add_option, check_args


def add_parser(subparsers) -> argparse.ArgumentParser:
    p = subparsers.add_parser(
        "render", help="overlay video/images of a tracked run: capsules and skeleton over each "
        "camera's frames or masks, cameras side by side",
        description="Draw the run's fitted model over each camera's images (silhouette outlined) "
                    "or masks (silhouette-only grey, overlap blue, model-only orange), with the "
                    "frame's weight. --out FILE.mp4|.avi writes a video, FILE.png one frame, "
                    "anything else a folder of PNGs.")
    p.add_argument("run_dir", help="a folder written by ipf-jax track")
    add_common(p, "out", help="FILE.mp4 | FILE.avi | FILE.png (one frame) | DIR")
    add_common(p, "dataset")
    add_common(p, "cameras")
    bg = p.add_mutually_exclusive_group()
    bg.add_argument("--images", action="store_true", help="draw over camera images (default when "
                    "the dataset has them)")
    add_common(bg, "masks", help="draw over the silhouette masks")
    add_option(p, "frames", help="frame numbers of the run to draw: A:B (B excluded), A:, A:B:S or A "
               "(default: all)")
    add_common(p, "size", type=int, help=f"long side of each camera view in pixels (default: "
                   f"the camera's, within {MIN_SIDE}..{MAX_SIDE})")
    add_option(p, "fps", help="video frame rate (default: the run's)")
    add_common(p, "quiet")
    p.set_defaults(func=run)
    return p


def run(args: argparse.Namespace) -> int:
    check_args(args)  # --fps's own rule (0 is refused, not read as "the run's")
    background = "images" if args.images else "masks" if args.masks else None
    summary = render_run(args.run_dir, args.out, dataset=args.dataset, cameras=args.cameras,
                         background=background, frames=args.frames, size=args.size, fps=args.fps,
                         progress=not args.quiet)
    what = {"video": f"a {summary['fps']:g} fps video", "image": "one image",
            "folder": "PNG files"}[summary["kind"]]
    print(f"drew {summary['frames']} frame(s) of {', '.join(summary['cameras'])} over "
          f"{summary['background']} into {what}: {summary['out']}")
    return 0
