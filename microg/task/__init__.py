"""The pick-and-place task (paper, section 4.3), written once: its stages, holds, drops and places."""
