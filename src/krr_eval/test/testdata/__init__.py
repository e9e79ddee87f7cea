"""Test helpers of the tools' unittest suites (fake core CLIs)."""
