# A block of CPM concrete spheres hit by a concrete sphere, written as a YADE user writes it:
# it runs alone with `yade block_impact.py`, and unchanged through
# `python3 -m cli run cases/block_impact.toml`, which couples the block to an FE plate
# around it (the block is the plate's DE zone plus its bridging band).
from yade import pack

concrete = O.materials.append(CpmMat(young=33e9, poisson=0.2, frictionAngle=atan(0.8),
                                     sigmaT=4.8e6, epsCrackOnset=1e-4, relDuctility=30,
                                     density=2400 / 0.74, label='concrete'))
r = 0.015
O.bodies.append(pack.regularHexa(pack.inAlignedBox((0.30, 0.30, 0), (0.90, 0.90, 0.12)),
                                 radius=r, gap=0, material=concrete))

intR = 1.5  # cohesive links up to 1.5 x the sum of radii, on the first step only
O.engines = [
    ForceResetter(),
    InsertionSortCollider([Bo1_Sphere_Aabb(aabbEnlargeFactor=intR, label='aabb')]),
    InteractionLoop(
        [Ig2_Sphere_Sphere_ScGeom(interactionDetectionFactor=intR, label='ig2')],
        [Ip2_CpmMat_CpmMat_CpmPhys()],
        [Law2_ScGeom_CpmPhys_Cpm()],
    ),
    NewtonIntegrator(),
    PyRunner(command='report()', iterPeriod=100),
]
# 0.15 x PWave: under this 30 m/s impact CPM gains energy at larger steps once links
# break (0.3 and 0.5 blow up within 2 ms without numerical damping; docs/case-files.md)
O.dt = 0.15 * PWaveTimeStep()
O.step()
aabb.aabbEnlargeFactor = ig2.interactionDetectionFactor = 1.0

# the impactor: 2 mm above the block, too late for a cohesive contact
top = max(b.state.pos[2] + b.shape.radius for b in O.bodies)
impactor = O.bodies.append(sphere((0.6, 0.6, top + 0.002 + 0.04), 0.04, material=concrete))
O.bodies[impactor].state.vel = (0, 0, -30)


def report():
    print('iter %d, impactor at z = %.4f m' % (O.iter, O.bodies[impactor].state.pos[2]))


O.run(2000, True)
