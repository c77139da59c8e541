"""course_robot: see this folder's README.md."""
