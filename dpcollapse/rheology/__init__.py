"""rheology"""
