"""Environment classes. Make them with ``gymnasium.make`` after ``import track_envs``."""
