"""Generators and mkdocs hooks of the documentation site (not part of the package)."""
