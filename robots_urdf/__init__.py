"""The reference robots shipped with pincal (URDF with ``<loop>`` and ``<transmission>`` elements)."""
