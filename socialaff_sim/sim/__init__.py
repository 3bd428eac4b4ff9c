"""MuJoCo scene, replayed human, physics loop, sub-goal scoring and rendering."""
