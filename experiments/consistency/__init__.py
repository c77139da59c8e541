"""consistency: see this folder's README.md."""
