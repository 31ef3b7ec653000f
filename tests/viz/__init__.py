"""Tests of pictures and animations of forecasts."""
