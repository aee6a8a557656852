"""Figures like the chapter's, animations, and the process that draws figures while a run simulates
(matplotlib is imported inside these modules only).
"""
