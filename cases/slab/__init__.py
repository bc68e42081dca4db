"""The paper's slab impact (§5): its description and scales (spec), geometry, models (full
and coupled, built by orchestrator.builder), comparison, and the bending measurement of the FE
modulus (`python3 -m cases.slab.bending`)."""
from cases.slab.packings import make_packings
from cases.slab.zone import sensor_points, slab_bridging, slab_grid
from cases.slab.model import MODELS, SlabModel, concrete, fe_model, fe_weight
from cases.slab.runs import run
from cases.slab.scales import SCALES, SLAB
from cases.slab.spec import SlabSpec
