"""The studies' tests (see studies/README.md)."""
