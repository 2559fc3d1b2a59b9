"""Rendering: pinhole camera, ray-cast depth and part ids, sensor noise, view sampling."""
