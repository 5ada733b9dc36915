"""The impact laws as cone programs over the friction cones, and the conic backends."""
