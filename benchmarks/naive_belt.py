"""A naive pymunk belt sorter: the reference the batched BeltSorter-v0 is timed against.

The same scene (belt, walls, window, particle kinds, feed, sensor) written the way a pymunk
tutorial would: belt friction as a per-body ``PivotJoint`` + ``GearJoint`` to a kinematic belt
body (with ``max_force = μ m g``, Coulomb friction through the constraint solver), a Python
object per particle, per-body Python read-out of positions and velocities every frame, and
per-detection Python for the sensor. Not part of the library.
"""

from __future__ import annotations

import numpy as np
import pymunk

from track_envs.envs.belt_physics import GRAVITY, PARTICLE_KINDS, BeltParams


class NaiveBelt:
    """One frame per `step`, returning (detections, their truth ids, truth velocities)."""

    def __init__(self, params: BeltParams, kind: str, seed: int, dt: float = 0.01, noise_std: float = 1e-4):
        self.p = params
        self.kind = PARTICLE_KINDS[kind]
        self.rng = np.random.default_rng(seed)
        self.dt = dt
        self.noise_std = noise_std
        self.space = pymunk.Space()
        self.space.iterations = 10
        self.space.collision_slop = 5e-5
        self.belt = pymunk.Body(body_type=pymunk.Body.KINEMATIC)
        self.belt.velocity = (params.belt_speed, 0.0)
        self.space.add(self.belt)
        for y in (-0.01, params.window_width + 0.01):
            wall = pymunk.Segment(self.space.static_body, (-1.0, y), (2.0, y), 0.01)
            self.space.add(wall)
        self.particles: list[tuple[int, pymunk.Body, list]] = []
        self.next_id = 0
        self.log_intensity = 0.0
        for _ in range(round(params.warmup_time / dt)):
            self.step()

    def _drop(self) -> None:
        p, k, rng = self.p, self.kind, self.rng
        a = np.exp(-self.dt / p.feed_correlation_time)
        self.log_intensity = a * self.log_intensity + np.sqrt(1 - a * a) * rng.normal()
        s = p.feed_burstiness
        count = rng.poisson(p.feed_rate * self.dt * np.exp(s * self.log_intensity - 0.5 * s * s))
        for _ in range(count):
            body = pymunk.Body(k.mass, pymunk.moment_for_box(k.mass, (k.length, k.width)))
            body.position = (
                p.drop_x - p.drop_spread * rng.random(),
                0.5 * k.length + (p.window_width - k.length) * rng.random(),
            )
            speed = k.chute_speed + k.chute_speed_std * rng.normal()
            body.velocity = (speed, k.lateral_speed_std * rng.normal())
            body.angle = k.angle_std * rng.normal()
            shape = pymunk.Poly.create_box(body, (k.length, k.width), radius=0.0005)
            shape.friction = k.particle_friction
            shape.elasticity = k.restitution
            slide = pymunk.PivotJoint(self.belt, body, (0, 0), (0, 0))
            slide.max_bias = 0
            slide.max_force = k.belt_friction * k.mass * GRAVITY
            spin = pymunk.GearJoint(self.belt, body, 0.0, 1.0)
            spin.max_bias = 0
            spin.max_force = k.belt_friction * k.mass * GRAVITY * k.radius
            self.space.add(body, shape, slide, spin)
            self.particles.append((self.next_id, body, [shape, slide, spin]))
            self.next_id += 1

    def step(self) -> tuple[list[tuple[float, float]], list[int], list[tuple[float, float]]]:
        self._drop()
        self.space.step(self.dt)
        end = self.p.window_length + self.p.exit_margin
        kept = []
        detections, ids, velocities = [], [], []
        for pid, body, parts in self.particles:
            x, y = body.position
            vx, vy = body.velocity
            if x > end:
                self.space.remove(body, *parts)
                continue
            kept.append((pid, body, parts))
            if 0.0 <= x <= self.p.window_length:
                noise = self.noise_std
                detections.append((x + noise * self.rng.normal(), y + noise * self.rng.normal()))
                ids.append(pid)
                velocities.append((vx, vy))
        self.particles = kept
        order = self.rng.permutation(len(detections))
        return [detections[i] for i in order], [ids[i] for i in order], velocities
