"""Domains: fixed (``domain.fixed``) or moving with the material (``domain.moving``)."""
