"""failure_cases: see this folder's README.md."""
