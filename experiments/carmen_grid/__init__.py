"""carmen_grid: see this folder's README.md."""
