"""Shared helpers for the course's chapter scripts."""
