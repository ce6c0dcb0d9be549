"""diagnose/concealed"""
