"""Corner FastSLAM (1.0 and 2.0) as a small class over pure functions: the filter (``filter``:
``FastSLAM``, ``FastSLAMParams``), landmark EKF updates (``ekf``), data association
(``association``), the two proposals (``proposals``) and known association for diagnosis and the
optimum (``identities``). The loop over a log is ``mazeslam.pipeline.fastslam_run``."""
