"""Features of a scan: lines by split-and-merge (``lines``) and the corners and wall ends
FastSLAM observes, with their covariances (``corners``: ``CornerExtractor``)."""
