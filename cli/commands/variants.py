"""`variants`: the slab variants' measurement of full runs (cases.slab.variants): the peak under
the impact, the damaged volume and the share of the damage outside the DE zone."""

NAME = "variants"
HELP = ("variants DIR ...: full slab runs (or slab --seeds folders): peak under the impact, "
        "damaged volume, share of damaged volume and of links ω > 0.1 outside the DE zone")


def configure(p):
    p.add_argument("dirs", nargs="+", metavar="DIR", help="full run folder, or an ensemble folder")
    p.add_argument("--json", metavar="FILE", help="also write the figures to FILE (JSON)")


def run(args):
    from cases.slab.variants import measure_folders, table
    rows = measure_folders(args.dirs)
    if args.json:
        from pathlib import Path
        from common.files import write_json
        write_json(Path(args.json), rows)
    print(table(rows))
    return 0
