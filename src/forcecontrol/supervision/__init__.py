"""What watches a running controller and steps in: the safety layer, contact transitions, the
stability monitor and the online stiffness estimate.
"""
