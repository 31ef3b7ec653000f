"""Simple reference predictors."""
