"""A pygame window for ``render_mode="human"``: the only module that imports pygame (lazily)."""

from __future__ import annotations

import os
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

__all__ = ["HumanWindow"]


class HumanWindow:
    """Shows RGB frames in a pygame window (for ``render_mode="human"``).

    The window is created lazily on the first [`show`][track_envs.envs.render_window.HumanWindow.show], sized
    to the frame. pygame is imported only then; with ``SDL_VIDEODRIVER=dummy`` it works headless.

    Args:
        title: Window caption.
        fps: Frame rate to hold [`show`][track_envs.envs.render_window.HumanWindow.show] to (``<= 0``: no
            limit).
    """

    def __init__(self, title: str, fps: int) -> None:
        self.title = title
        self.fps = int(fps)
        self.quit_requested = False
        self._pygame: Any = None
        self._screen: Any = None
        self._clock: Any = None
        self._size: tuple[int, int] | None = None

    @staticmethod
    def _import_pygame() -> Any:
        """Imports pygame or raises `gymnasium.error.DependencyNotInstalled`."""
        os.environ.setdefault("PYGAME_HIDE_SUPPORT_PROMPT", "1")
        try:
            import pygame
        except ImportError as exc:
            from gymnasium.error import DependencyNotInstalled

            raise DependencyNotInstalled(
                'pygame is not installed; run `pip install "track-envs[render]"`'
            ) from exc
        return pygame

    @property
    def is_open(self) -> bool:
        """Whether the window currently exists."""
        return self._screen is not None

    def show(self, frame: ArrayLike) -> None:
        """Displays one frame, pumps window events and waits to hold the frame rate.

        Args:
            frame: ``uint8`` image of shape (H, W, 3).

        Raises:
            gymnasium.error.DependencyNotInstalled: If pygame is not installed.
            ValueError: If ``frame`` is not (H, W, 3).
        """
        img = np.asarray(frame)
        if img.ndim != 3 or img.shape[2] != 3:
            raise ValueError(f"expected an (H, W, 3) frame, got {img.shape}")
        if img.dtype != np.uint8:
            img = np.clip(img, 0, 255).astype(np.uint8)
        if self._pygame is None:
            self._pygame = self._import_pygame()
        pygame = self._pygame
        size = (int(img.shape[1]), int(img.shape[0]))
        if self._screen is None or self._size != size:
            if not pygame.display.get_init():
                pygame.init()
                pygame.display.init()
            self._screen = pygame.display.set_mode(size)
            pygame.display.set_caption(self.title)
            self._size = size
        if self._clock is None:
            self._clock = pygame.time.Clock()
        for event in pygame.event.get():
            if event.type == pygame.QUIT:
                self.quit_requested = True
        surface = pygame.surfarray.make_surface(np.ascontiguousarray(img.transpose(1, 0, 2)))
        self._screen.blit(surface, (0, 0))
        pygame.display.flip()
        self._clock.tick(max(self.fps, 0))

    def close(self) -> None:
        """Closes the window (safe to call repeatedly, or before any
        [`show`][track_envs.envs.render_window.HumanWindow.show])."""
        if self._pygame is not None and self._screen is not None:
            self._pygame.display.quit()
            self._pygame.quit()
        self._screen = None
        self._clock = None
        self._size = None
