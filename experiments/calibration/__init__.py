"""calibration: see this folder's README.md."""
