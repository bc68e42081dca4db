"""A coupled 3D elastic block (spec, model) and the paper's 3D check (check)."""
from cases.block3d.check import ShearCheck, relative_rms, run_shear_check
from cases.block3d.model import CoupledBlock, WeightedEnergy
from cases.block3d.spec import PACKINGS, BlockSpec, UniformOverlap, cubic_lattice
