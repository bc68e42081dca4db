"""The YADE scene: engines for dynamics of cohesive-frictional CPM spheres."""

from dataclasses import dataclass

import numpy as np

from yade_side import import_yade
from yade_side.affine import link_stiffness
from yade_side.memory import Fields

# Cohesive links are made between spheres up to this factor of the sum of radii apart
# (first step only), so that a random dense packing gets ~11–12 links per sphere.
INTERACTION_RADIUS = 1.5
# A cohesive link whose CPM damage ω exceeds this is broken: YADE deletes it, and damage.py
# counts it broken. Kept (omegaThreshold = 1, YADE's default), fully damaged links made the
# slab impact gain energy without bound (small full slab at 0.15 × PWave: kinetic energy
# 40 kJ → 283 kJ by step 2,600, half of it in sphere spins; with 0.99 it decays, docs/slab.md).
# A likely cause: the CPM law turns a link's total shear strain with the contact but not its
# plastic part, so a broken link that keeps sliding and turning gets a spurious elastic strain.
BROKEN_OMEGA = 0.99
# Past this damage a link's shear stiffness is set to zero (cpm_engines with
# shear_release): the public CPM law keeps a cracked link's full shear stiffness and, in
# compression, its full friction until deletion; that friction across cracks is what makes the
# 40 m/s slab impact gain energy at 0.3 × PWave (docs/performance.md). The normal law is kept.
SHEAR_RELEASE_OMEGA = 0.9


def reset_scene():
    yade = import_yade()
    yade.Omega().reset()


def cpm_engines(dt=None, dt_safety=0.8, threshold=BROKEN_OMEGA, shear_release=0.0):
    """O.engines for explicit dynamics of CpmMat spheres: no damping, no gravity, fixed Δt.

    Δt = dt if given, else dt_safety × PWaveTimeStep(). `threshold` is
    Law2_ScGeom_CpmPhys_Cpm.omegaThreshold (links are deleted once damage exceeds it; 1 keeps
    them: see BROKEN_OMEGA). Only contacts of the first step become cohesive links (cohesiveThresholdIter=1):
    an impactor never sticks. shear_release = T > 0 (s): release_cracked_shear() every
    round(T / Δt) steps (at least 1; a PyRunner after the interaction loop): a period in time,
    so that the physics is the step's own. Returns (law, newton). Call
    create_cohesive_links() once the bodies are in."""
    yade = import_yade()
    from yade import utils, wrapper as w
    O = yade.Omega()
    law = w.Law2_ScGeom_CpmPhys_Cpm(omegaThreshold=threshold)
    newton = w.NewtonIntegrator(damping=0.0, gravity=(0, 0, 0))
    O.engines = [
        w.ForceResetter(),
        w.InsertionSortCollider([w.Bo1_Sphere_Aabb(aabbEnlargeFactor=INTERACTION_RADIUS,
                                                   label="aabb")]),
        w.InteractionLoop([w.Ig2_Sphere_Sphere_ScGeom(
                              interactionDetectionFactor=INTERACTION_RADIUS, label="ig2")],
                          [w.Ip2_CpmMat_CpmMat_CpmPhys(cohesiveThresholdIter=1)], [law]),
        newton,
    ]
    O.dynDt = False
    O.dt = dt if dt is not None else dt_safety * utils.PWaveTimeStep()
    if shear_release < 0:
        raise ValueError(f"shear release period must be >= 0 s, got {shear_release!r}")
    if shear_release:
        O.engines = O.engines + [w.PyRunner(
            iterPeriod=max(1, round(shear_release / O.dt)), label="shear_release",
            command="import yade_side.scene; yade_side.scene.release_cracked_shear()")]
    return law, newton


def create_cohesive_links():
    """One step with the enlarged detection radius creates the cohesive links; then the
    factors go back to 1 so that later contacts are ordinary frictional ones.

    That step runs the collider without its Verlet distance: the bounds enlarged 1.5 × and
    then by the Verlet distance make ~4 candidate pairs per link (a 2.5 × 2 × 0.28 m slab:
    237,401 interactions for 54,883 links), whose memory the process keeps after the next
    collider run drops them; without it, ~2 per link. The next step's collider run (Verlet
    distance back) bounds the bodies as usual."""
    yade = import_yade()
    O = yade.Omega()
    colliders = [e for e in O.engines if isinstance(e, yade.wrapper.InsertionSortCollider)]
    verlet = [c.verletDist for c in colliders]
    for c in colliders:
        c.verletDist = 0.0
    O.step()
    for c, distance in zip(colliders, verlet):
        c.verletDist = distance
    for engine in O.engines:
        if isinstance(engine, yade.wrapper.InsertionSortCollider):
            for functor in engine.boundDispatcher.functors:
                functor.aabbEnlargeFactor = 1.0
        if isinstance(engine, yade.wrapper.InteractionLoop):
            for functor in engine.geomDispatcher.functors:
                functor.interactionDetectionFactor = 1.0


def sort_afresh():
    """Bodies were added to a running scene: its collider sorts its bounds afresh at the next
    step (doSort) instead of inserting the new ones, which it does by moving each new bound
    through the sorted ones: O(added × all), seconds at a time in a grown zone of 80,000
    spheres (docs/auto-zone.md, "What a conversion costs")."""
    yade = import_yade()
    for engine in yade.Omega().engines:
        if isinstance(engine, yade.wrapper.InsertionSortCollider):
            engine.doSort = True


def link_pairs(ref, radius, new):
    """The pairs (m, 2) of indices into `ref` that the first step of a scene at the reference
    positions `ref` (n, 3), of radii `radius`, would link (create_cohesive_links: centres
    closer than INTERACTION_RADIUS × the sum of the radii), of which at least one is `new`
    (mask): the links spheres added to a running scene need."""
    from scipy.spatial import cKDTree
    new = np.flatnonzero(new)
    if len(new) == 0:
        return np.empty((0, 2), int)
    near = cKDTree(ref).query_ball_point(ref[new], INTERACTION_RADIUS * 2 * radius.max())
    a = np.repeat(new, [len(n) for n in near])
    b = np.concatenate([np.asarray(n, int) for n in near])
    is_new = np.zeros(len(ref), bool)
    is_new[new] = True
    keep = (a != b) & ~(is_new[b] & (b < a)) & (
        np.linalg.norm(ref[a] - ref[b], axis=1) < INTERACTION_RADIUS * (radius[a] + radius[b]))
    return np.column_stack([a[keep], b[keep]])


def add_cohesive_links(pairs, radii, ref_length, young, poisson, weight=1.0):
    """Cohesive links between the bodies of `pairs` (m, 2) ids of a running scene, as its
    first step made its links at the reference positions (create_cohesive_links), whatever
    the bodies' positions now: Ip2 makes an interaction cohesive only before its
    cohesiveThresholdIter (raised while they are made), and the law, at an interaction's
    first step, sets its reference length, cross-section, reference penetration and
    stiffnesses from the distance then; these are set here as the law would at
    `ref_length` (m,) (yade_side.affine.link_stiffness), with the ends' `radii`, the
    unweighted E = mean `young` and G = mean `poisson` × E of the two ends ((m, 2) each: a
    weighted sphere's material carries its β), cross-section and stiffnesses × `weight`
    ((m,) or a scalar: the links' energy weight, yade_side.weighting), and the interactions
    are made no longer fresh. Returns them (NewLinks)."""
    yade = import_yade()
    from yade import utils
    O = yade.Omega()
    ip2 = [f for e in O.engines if isinstance(e, yade.wrapper.InteractionLoop)
           for f in e.physDispatcher.functors if isinstance(f, yade.wrapper.Ip2_CpmMat_CpmMat_CpmPhys)]
    thresholds = [f.cohesiveThresholdIter for f in ip2]
    for f in ip2:
        f.cohesiveThresholdIter = O.iter + 1
    try:
        made = [utils.createInteraction(int(a), int(b)) for a, b in pairs]
    finally:
        for f, t in zip(ip2, thresholds):
            f.cohesiveThresholdIter = t
    E = 0.5 * (young[:, 0] + young[:, 1])
    G = 0.5 * (poisson[:, 0] + poisson[:, 1]) * E
    if not made:
        return NewLinks([], np.empty((0, 2), int), [])
    section, kn, ks = (weight * v for v in
                       link_stiffness(radii[:, 0], radii[:, 1], ref_length, E, G))
    phys, ends, made_real = [], [], O.iter - 1
    for i in made:
        i.iterMadeReal = made_real
        phys.append(i.phys)
        ends.append((i.id1, i.id2))
    fields = Fields(phys, LINK_FIELDS)
    fields.write(E=E, G=G, refLength=ref_length, crossSection=section,
                 refPD=radii[:, 0] + radii[:, 1] - ref_length, kn=kn, ks=ks,
                 epsFracture=fields.read("epsCrackOnset") * fields.read("relDuctility"))
    return NewLinks(made, np.array(ends, int), phys, fields)


# the CpmPhys fields add_cohesive_links sets and the links' energy reads (yade_side.transfer)
LINK_FIELDS = ("E", "G", "refLength", "crossSection", "refPD", "kn", "ks", "epsFracture",
               "epsCrackOnset", "relDuctility", "normalForce", "shearForce")


@dataclass
class NewLinks:
    """Links made in a running scene (add_cohesive_links): YADE's interactions, their ids
    (m, 2) as YADE holds them (id1, id2: the normal's direction), their CpmPhys and its
    LINK_FIELDS in memory (yade_side.memory.Fields), read once: each Python access to an
    interaction costs microseconds."""
    interactions: list
    ids: np.ndarray
    phys: list
    fields: object = None

    def __len__(self):
        return len(self.interactions)


def settle_forces():
    """The interactions' forces at the current positions, with nothing moved: one step of zero
    length (what the law's energy reads; the next real step computes the same forces first).
    Only for a scene whose engines do not couple inside the step."""
    O = import_yade().Omega()
    dt = O.dt
    O.dt = 0.0
    try:
        O.step()
    finally:
        O.dt = dt


def keep_engine_phase(steps):
    """After a scene was built afresh mid-run (its step counter starts again), periodic
    engines (the shear release) go on at the phase of the run's `steps`: each runs next
    where it would have in the one scene. Else conversions closer than its period would
    never let it run."""
    yade = import_yade()
    O = yade.Omega()
    for e in O.engines:
        if isinstance(e, yade.wrapper.PeriodicEngine) and e.iterPeriod > 0:
            e.iterLast = O.iter - steps % e.iterPeriod


def release_cracked_shear(omega=SHEAR_RELEASE_OMEGA):
    """Zero shear stiffness (CpmPhys.G, which the law multiplies the elastic shear strain by)
    on the cohesive links whose damage exceeds omega; returns how many were released now.
    A walk over O.interactions (~1 µs per entry): run it every few tens of steps."""
    yade = import_yade()
    released = 0
    for i in yade.Omega().interactions:
        phys = i.phys
        if phys is not None and phys.isCohesive and phys.G != 0 and phys.omega > omega:
            phys.G = 0.0
            released += 1
    return released


def cpm_law():
    """The scene's Law2_ScGeom_CpmPhys_Cpm (for its elastic energy), or None."""
    yade = import_yade()
    for e in yade.Omega().engines:
        if isinstance(e, yade.wrapper.InteractionLoop):
            for law in e.lawDispatcher.functors:
                if isinstance(law, yade.wrapper.Law2_ScGeom_CpmPhys_Cpm):
                    return law
    return None


def link_energy(phys):
    """One CpmPhys's elastic energy as Law2_ScGeom_CpmPhys_Cpm.elasticEnergy() sums it: the
    normal stiffness damaged in tension only."""
    kn = (1.0 - (phys.omega if phys.epsN > 0 else 0.0)) * phys.kn
    return 0.5 * (phys.normalForce.squaredNorm() / kn + phys.shearForce.squaredNorm() / phys.ks)


def block_dofs(ids, dofs):
    """Hold the degrees of freedom `dofs` (YADE's blockedDOFs letters, e.g. "z") of the bodies
    `ids` (a support; set once at build time)."""
    O = import_yade().Omega()
    for i in ids:
        O.bodies[int(i)].state.blockedDOFs = dofs
