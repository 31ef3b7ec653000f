"""Datasets: the ETH/UCY benchmark (download with checksums, its files, parts and subsets) and
datasets of one's own (descriptions with named, balanced sources)."""
