"""The pieces every other package stands on, and nothing of SLAM: SE(2) poses and angles
(``geometry``), which bearing each range of a scan has (``beams``), settings as frozen dataclasses
read from TOML with errors that say where and why (``config``), the size limits of inputs
(``limits``), the odometry motion model (``motion``), resampling that returns indexes
(``resampling``), the omnidirectional camera's mirror model (``mirror``) and output folders checked
before work starts (``outputs``)."""
