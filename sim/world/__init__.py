"""The world a scene declares (layer 0): the scenario schema and the motion of its objects."""
