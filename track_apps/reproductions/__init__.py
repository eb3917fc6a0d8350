"""Paper reproductions that run the trackers (applications on top of them, like bench and tuning):
[`track_apps.reproductions.jung2019`][track_apps.reproductions.jung2019] (the particle-filter experiments of
Jung et al.), used as a module (``from track_apps.reproductions import jung2019``)."""

from track_apps.reproductions import jung2019
from track_envs.infra.lazy import lazy_exports

__getattr__, __dir__, __all__ = lazy_exports(__name__, __file__)
