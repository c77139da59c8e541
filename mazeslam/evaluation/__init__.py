"""Numbers only, no plots and no commands: trajectory and map metrics (``metrics``), the one
scoring of a SLAM run against truth (``scoring``), consistency (NEES, NIS; ``consistency``),
Kümmerle et al.'s relation metric (``relations``), map sharpness for logs without truth
(``sharpness``) and corner precision and recall against the true corners (``corner_quality``)."""
