import os

# numpy's OpenBLAS threads only oversubscribe the cores YADE uses (the project's dense algebra
# is small: the relaxation rule's solves took minutes instead of seconds under load), and a
# thread count that follows the machine would change the last bits of results between machines
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

from cli.main import main  # noqa: E402  (after the setting, before numpy loads)

raise SystemExit(main())
