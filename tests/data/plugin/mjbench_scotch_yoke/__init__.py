"""A Scotch yoke and a lead-lag speed controller for mjbench, as an installed plugin."""
