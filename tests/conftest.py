"""The suite's runs are bit-identical only on one YADE thread (yade_side.import_yade); the
runs it starts as processes inherit this."""
import os

os.environ["OMP_NUM_THREADS"] = "1"
