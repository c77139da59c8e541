"""particles: see this folder's README.md."""
