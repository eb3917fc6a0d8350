"""Paper reproductions that run the trackers (applications on top of them, like bench and tuning):
:mod:`agents.reproductions.jung2019` (the particle-filter experiments of Jung et al.), used as a
module (``from agents.reproductions import jung2019``)."""

from agents.reproductions import jung2019

__all__ = ["jung2019"]
