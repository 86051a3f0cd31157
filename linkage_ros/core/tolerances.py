"""Tolerances the front ends share with the core as defaults (no dependencies: the CLI's parser
reads them before it imports any solver)."""

#: the loop-closure tolerance a Newton solve is held to unless asked otherwise: the largest
#: residual as a fraction of the length scale (the node's ``tolerance``, ``--tol``)
NEWTON_TOL = 1e-12
#: the loosest tolerance a solve takes: a residual of 1e-3 of the length scale is already a
#: mechanism 0.1 % apart at its joints; beyond it a Newton solve stops at its first iterate
#: (tolerance 1: a target's slider 0.17 m from where it was asked, answered OK), so an answer
#: would be neither the target nor a configuration of the mechanism
NEWTON_TOL_MAX = 1e-3
