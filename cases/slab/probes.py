"""Sensors of other DE zones in a full slab run. A coupled model places its sensors relative to
its own DE zone and band (cases.slab.zone.sensor_points); the full model's physics does not
depend on the zone (no FE, β = 1, the DE time step alone), only where its sensors sit. So one
full run can stand for the full run of every zone: beside its own sensors it records, for each
other layout (a label and the slab grid of its zone), the sensors a full run with that zone would
have, named "LABEL/SENSOR". The placement is SlabModel's, applied to the layout's grid."""
import numpy as np

from cases.slab.zone import sensor_points

SEPARATOR = "/"


def probe_name(label, sensor):
    return f"{label}{SEPARATOR}{sensor}"


def full_names(label, names):
    """The full run's columns for the sensors `names` of a zone's layout `label` (None: the
    full run's own); the sensor under the impact is the same point in every layout."""
    return [n if label is None or n == "under_impact" else probe_name(label, n) for n in names]


def layout_sensors(model, spec, grid):
    """(names, sphere indices, positions) of the full `model`'s sensors for the DE zone of
    `grid` and the band of `spec` (its layers): the spheres nearest the layout's points, and
    for "fe_node" the sphere nearest the grid node nearest the bridging sphere (SlabModel's
    rule; in-plane size and layers through the thickness are those of every layout of the
    slab)."""
    pos = model.slab.ref_pos
    points = sensor_points(spec, grid)
    idx = [int(np.argmin(np.linalg.norm(pos - p, axis=1))) for p in points.values()]
    node = model._fe_node_position(pos[idx[-1]])
    idx.append(int(np.argmin(np.linalg.norm(pos - node, axis=1))))
    return list(points) + ["fe_node"], idx, pos[idx]


def add_probes(model, layouts):
    """Give the built full `model` its own sensors and those of `layouts` ({label: (spec,
    grid)}: the coupled run's description and the grid of its zone);
    the position-independent under_impact sensor is not repeated. Returns the sensor names."""
    if model.fe is not None:
        raise ValueError("probes of other DE zones are for the full model (it has no FE)")
    names, idx, positions = layout_sensors(model, model.spec, model.grid)
    names, idx, positions = list(names), list(idx), [positions]
    for label, (spec, grid) in layouts.items():
        n, i, p = layout_sensors(model, spec, grid)
        keep = [k for k, name in enumerate(n) if name != "under_impact"]
        names += [probe_name(label, n[k]) for k in keep]
        idx += [i[k] for k in keep]
        positions.append(p[keep])
    model.set_sensors(names, idx, [], np.vstack(positions))
    return names


def run_full(spec, layouts, out, quiet=False, start=None, resume=False):
    """The full slab of `spec` with the probes of `layouts`, run into `out` (made by
    `start()` once the model is built, if given), or carried on from its checkpoint there
    (resume: refused if it was written with other probes); returns its summary."""
    from cases.slab.model import SlabModel, run_built
    from orchestrator.run.inputs import spec_inputs
    m = SlabModel(spec, "full")
    names = add_probes(m, layouts)
    if start is not None:
        out = start()
    inputs = spec_inputs(spec, "full")
    inputs["sensors"] = names
    return run_built(m, out, quiet, resume, inputs=inputs)
