"""Forecasting new tracks with a trained model."""
