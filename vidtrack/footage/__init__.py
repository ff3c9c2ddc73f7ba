"""Footage: frame sources (videos, image folders, Phantom .cine), the time base, frame export."""
