"""Files in and out: datasets, safe writes, calibrated URDF text, reports as data."""
