"""Canonical equations of motion and event-driven simulation (Section 2.2, piece-wise analysis)."""
