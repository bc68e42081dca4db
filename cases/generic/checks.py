"""Checks of a generic case that need its models built, for what would otherwise be accepted
or snapped silently (docs/case-files.md, "Refused or warned"): a bridging band cut by the
mesh's edge or not filled with spheres, an element size that is not the mesh's, the number of
steps, and sensors far from what they are put on. Each appends one line per problem."""
import math

import numpy as np

from orchestrator.casefile import MAX_STEPS

SIZE_REFUSED = 2.0          # coupling.element_size this far from the mesh's is refused ...
SIZE_WARNED = 1.25          # ... and warned about from this far
NAMES = "xyz"


def band_in_mesh(bridging, mesh_lo, mesh_hi, layers, problems):
    """Along each zone axis, the band ends inside the mesh, on the sides where the zone does
    not reach the mesh's edge (there the structure ends and so does the band): a band cut by
    the edge has weights that never reach the FE side."""
    zone, width = bridging.zone, bridging.width
    size = width / layers
    tol = 1e-9 * max(1.0, float(np.abs(mesh_hi - mesh_lo).max()))
    room = []
    for a in zone.axes:
        for bound, edge, sign in ((zone.lo[a], mesh_lo[a], -1), (zone.hi[a], mesh_hi[a], 1)):
            gap = sign * (edge - bound)          # distance from the zone to the mesh's edge
            if gap <= tol:
                continue                         # the zone reaches the edge: no band there
            room.append(gap)
            if width > gap + tol:
                problems.append(
                    f"coupling.layers = {layers}: the bridging band is {width:g} m wide "
                    f"({layers} × element size {size:g} m) and reaches {NAMES[a]} = "
                    f"{bound + sign * width:g} m, beyond the mesh's edge {NAMES[a]} = {edge:g} m")
    if problems and room:
        problems.append(f"coupling.layers: at most {int(min(room) / size + 1e-9)} layers of "
                        f"{size:g} m fit between the DE zone and the mesh's edges")


def measured_element_size(bridging, nodes, cell_nodes):
    """The depth (out of the DE zone, along its axes) spanned by the mesh's cells that touch
    the zone: the thickness of the first bridging layer; median over those cells."""
    zone = bridging.zone
    depth = zone.depth(nodes)[cell_nodes]           # (cells, nodes per cell)
    outside = depth.max(axis=1) > 0
    lo = depth.min(axis=1)
    scale = float(np.abs(nodes).max()) or 1.0
    touching = outside & (np.abs(lo) <= 1e-6 * scale)
    if not touching.any():                          # a mesh off the zone: the nearest cells
        nearest = lo[outside].min()
        touching = outside & (lo <= nearest + 1e-6 * scale)
    return float(np.median(depth.max(axis=1)[touching] - np.maximum(lo[touching], 0.0)))


def element_size(given, measured, problems, warnings):
    """coupling.element_size against the mesh's own size near the DE zone."""
    ratio = given / measured
    text = (f"coupling.element_size = {given:g} m is {ratio:.3g} × the mesh's element "
            f"size at the DE zone ({measured:.3g} m, the first layer's thickness): the band is "
            f"coupling.layers × element_size wide")
    if max(ratio, 1 / ratio) > SIZE_REFUSED:
        problems.append(f"{text}; give the mesh's element size (within a factor "
                        f"{SIZE_REFUSED:g})")
    elif max(ratio, 1 / ratio) > SIZE_WARNED:
        warnings.append(text)


def band_filled(bridging, pos, radius, problems):
    """The spheres reach the band's outer face on each side where there is a band (within a
    sphere diameter): beyond them the band would hold FE weighted α < 1 and nothing else."""
    zone, width = bridging.zone, bridging.width
    d = 2 * float(radius.max())
    for a in zone.axes:
        for bound, sign in ((zone.lo[a], -1), (zone.hi[a], 1)):
            side = sign * (pos[:, a] - bound) > 0
            reach = float((sign * (pos[side, a] - bound) + radius[side]).max(initial=0.0))
            if reach < width - d:
                problems.append(
                    f"coupling: the spheres reach {NAMES[a]} = {bound + sign * reach:g} m, "
                    f"{width - reach:.3g} m short of the bridging band's outer face "
                    f"{NAMES[a]} = {bound + sign * width:g} m: the band must be full of "
                    f"spheres (fewer coupling.layers, or a larger DE part)")


def steps(time, dt, problems, notes):
    """The run's number of steps from time.steps or time.duration; None if refused."""
    if "steps" in time:
        return time["steps"]
    if "duration" not in time:          # de.current (cli.attach): YADE's loop decides
        return None
    duration = time["duration"]
    n = duration / dt
    if n < 1 - 1e-9:
        problems.append(f"time.duration = {duration:g} s is shorter than one time step "
                        f"({dt:.4g} s): nothing would be simulated")
        return None
    if n > MAX_STEPS:
        problems.append(f"time.duration = {duration:g} s needs {n:.3g} steps of {dt:.4g} s, "
                        f"more than {MAX_STEPS:.0e}")
        return None
    count = math.ceil(n - 1e-9)
    if abs(count - n) > 1e-6 * n:
        notes.append(f"time.duration = {duration:g} s is {n:.4g} time steps of {dt:.4g} s: "
                     f"the run makes {count} steps ({count * dt:.6g} s)")
    return count


def fe_snap_bound(element_size, nodes, cell_nodes):
    """Farthest an FE node may be from a sensor's point: the element size, or half the largest
    cell diagonal (a point inside any cell has a node that near)."""
    corners = nodes[cell_nodes]
    half = 0.5 * np.linalg.norm(corners.max(axis=1) - corners.min(axis=1), axis=1).max()
    return max(float(element_size), float(half))


def snapped(k, sensor, kind, on, distance, bound, problems, notes):
    """A point sensor on the `kind` (sphere, FE node) described by `on`, at `distance` from
    its point: noted, refused beyond `bound` (value, what it is)."""
    p = ", ".join(f"{x:g}" for x in sensor["point"])
    line = (f"sensors[{k}] ({sensor['name']!r}) at ({p}): on {kind} {on}, {distance:.3g} m "
            f"from the point")
    if distance > bound[0]:
        problems.append(f"{line}, farther than {bound[0]:.3g} m ({bound[1]}): no {kind} lies "
                        f"near this point (outside the model, or in the other model's part)")
    else:
        notes.append(line)
