"""Random-tree planners (RRT, bidirectional RRT, RRT*, C-RRT*) and their steering."""
