"""Check that the stack the project runs on is importable, and say what it is."""


def check():
    import dolfinx
    import h5py
    import meshio
    import mpi4py
    import numpy
    import petsc4py
    import scipy
    from yade_side import import_yade
    yade = import_yade()
    import yade.config
    print(f"YADE {yade.config.version}, dolfinx {dolfinx.__version__}, "
          f"numpy {numpy.__version__}, scipy {scipy.__version__}")
