"""Pedestrian groups: trajectory distances, agglomerative clustering, label evaluation."""
