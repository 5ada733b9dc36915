"""The scenes of convimpact (installed as ``convimpact.problems``).

Each module builds one mechanism of Pereira & Nikravesh (1996) or a test case, as small as
the scene needs.
"""
