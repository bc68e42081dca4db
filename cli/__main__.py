import os

# numpy's OpenBLAS threads only oversubscribe the cores YADE uses (the project's dense algebra
# is small: the relaxation rule's solves took minutes instead of seconds under load), and a
# thread count that follows the machine would change the last bits of results between machines
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import logging  # noqa: E402

# the program's log handler, at WARNING: the FE forms' compilers (ffcx, cffi through setuptools)
# lower the root logger to INFO and would print every C compilation of a cold cache
logging.basicConfig(format="%(levelname)s:%(name)s:%(message)s")
logging.getLogger().handlers[0].setLevel(logging.WARNING)

from cli.main import main  # noqa: E402  (after the setting, before numpy loads)

raise SystemExit(main())
