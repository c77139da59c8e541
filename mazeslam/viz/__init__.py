"""Drawing, and nothing that computes results: shared plot helpers (``plots``), corner FastSLAM's
figure and animation (``slam_figure``, ``slam_view``), the live view (``live``), the grid filter's
figure and animation (``grid_figure``, ``grid_animation``), the optimum's figure
(``smooth_figure``) and the corner command's figures and report (``corner_plots``,
``corner_report``)."""
