"""mrclam: see this folder's README.md."""
