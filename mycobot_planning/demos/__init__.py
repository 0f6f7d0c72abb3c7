"""Runnable demonstrations used by scripts/demo.sh and the README."""
