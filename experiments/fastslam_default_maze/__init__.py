"""fastslam_default_maze: see this folder's README.md."""
