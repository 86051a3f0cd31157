"""The kinds of step a closed-form plan is made of (core.plan compiles them, core.execute runs
them)."""

from __future__ import annotations

from enum import StrEnum


class StepKind(StrEnum):
    """What a plan step does (the module docstring describes each)."""

    GROUND = 'ground'  # place the ground's body at rest
    KNOWN_POINT = 'known_point'  # a point given by the command
    TWO_POINTS = 'two_points'  # rigid transfer: a body from two of its known points
    POINT_ANGLE = 'point_angle'  # a body from a known point and its known orientation
    ANGLE = 'angle'  # a body's orientation from another's and a known angle
    RRR = 'circle_circle'  # RRR dyad: a point on two circles
    RRP = 'circle_line'  # RRP dyad: a slider point on a circle and a line
    RPR = 'line_through'  # RPR dyad: a guide turned so its line passes a known point


BRANCHING = (StepKind.RRR, StepKind.RRP, StepKind.RPR)
