"""Tracking: automatic initialisation, body origin positioning, floor contact, and the tracker that
runs a filter over a dataset's frames and writes the run directory.
"""
