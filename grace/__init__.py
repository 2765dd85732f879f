"""GRACE: learning robotic assembly sequence planning (Atad, Feng et al., IROS 2023)."""
