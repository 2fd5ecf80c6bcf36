"""Output: pictures and tables of results for people and other tools.

Renders what `model` and `fe` computed; computes nothing new. May import every stage
before it (scene, reference, contact, laws, statics, model, fe).
"""
