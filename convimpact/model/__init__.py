"""Joint-coordinate models of mechanisms (Sections 2-3 of the paper)."""
