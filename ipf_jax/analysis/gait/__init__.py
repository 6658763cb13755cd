"""Gait analysis: walking trajectories -> heel strikes, toe-offs, spatio-temporal parameters.

Pipeline (one module per concept): :mod:`.io` / :mod:`.markers` read files into
:class:`Trajectories`; :mod:`.filtering` fills short gaps and low-passes; :mod:`.direction` finds
the walking direction and straight parts; :mod:`.events` detects heel strikes and toe-offs;
:mod:`.parameters` and :mod:`.angles` measure steps, strides and joint curves; :mod:`.analysis`
ties them together (:func:`analyse`); :mod:`.report` and :mod:`.plots` write the outputs;
:mod:`.cli` is the ``ipf-jax gait`` command.
"""
from .analysis import GaitResult, analyse
from .io import load
from .trajectories import Trajectories, make_trajectories

__all__ = ["GaitResult", "Trajectories", "analyse", "load", "make_trajectories"]
