"""The experiments, one folder per question; run each script from the repository root as a module:
``python -m experiments.<folder>.<script>`` (see experiments/README.md)."""
