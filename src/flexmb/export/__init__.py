"""Export of results to files for outside viewers.

The submodules import their third-party writers (meshio) only when they are
imported themselves, so ``import flexmb`` stays free of them::

    from flexmb.export.vtk import export_vtk
"""

__all__: list[str] = []
