"""`render`: 3D pictures of a run's folder drawn by ParaView, offscreen (PNG)."""
from cli.commands._options import add_out, ranged

NAME = "render"
HELP = ("render RUN_DIR [--times T ...] [--animate] [--out DIR]: ParaView pictures of a run, "
        "cut through the impact point (spheres by damage, FE by displacement)")


def configure(p):
    p.add_argument("run_dir", metavar="RUN_DIR", help="a run's results folder")
    p.add_argument("--times", type=ranged(0, 1e3, low_open=False), nargs="+", metavar="T",
                   help="simulated times (s); each picture shows the nearest frame "
                        "(default: a third, two thirds and the end of the run)")
    p.add_argument("--animate", action="store_true",
                   help="also a film over every frame, animation.avi (Motion JPEG)")
    add_out(p, "folder for the pictures (default RUN_DIR/render)", required=False)


def run(args):
    from pathlib import Path
    from cli.render import render
    out = Path(args.out) if args.out else Path(args.run_dir) / "render"
    for path, times in render(args.run_dir, out, args.times, args.animate, args.force):
        shown = f"t = {times[0]:.4e} s" if len(times) == 1 else f"{len(times)} frames"
        print(f"{shown}: {path}")
    return 0
