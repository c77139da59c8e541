"""smoother: see this folder's README.md."""
