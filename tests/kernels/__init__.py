"""Kernel-vs-reference tests: every numba kernel against its numpy reference in tests/reference.

This directory is a package so that its test modules, named after the kernel modules
(test_fabric.py, test_phases.py, ...), do not clash with tests/unit's modules of the same name.
"""
