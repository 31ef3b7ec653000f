"""Reports built on the scores: the paper's tables, the project's targets, diagnostics, the
out-of-domain section and reports on datasets of one's own."""
