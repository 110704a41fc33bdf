"""Plumbing every layer may use: errors, argument checks, atomic writes, the verified
resumable store, the memory guard, progress bars. Imports nothing else of envfit.
"""
