"""Descriptions, data only: sensor and motor ports, bodies (segments, joints, sites, cameras) and worlds
(ground, objects, sky, odour scene). Imports nothing of the core but its base (errors, config)."""
