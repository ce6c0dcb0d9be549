"""replicate"""
