"""Pictures of scenes, groups and predictions (matplotlib, no screen needed)."""
