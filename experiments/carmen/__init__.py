"""carmen: see this folder's README.md."""
