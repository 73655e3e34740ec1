"""Backends: the kinematic point-agent engine, and (with their extras) MuJoCo and PyBullet.

The only package that imports a physics engine. Each backend registers under the entry-point
group ``neuronav.backends``.
"""
