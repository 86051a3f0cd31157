"""Tolerances the front ends share with the core as defaults (no dependencies: the CLI's parser
reads them before it imports any solver)."""

#: the loop-closure tolerance a Newton solve is held to unless asked otherwise: the largest
#: residual as a fraction of the length scale (the node's ``tolerance``, ``--tol``)
NEWTON_TOL = 1e-12
