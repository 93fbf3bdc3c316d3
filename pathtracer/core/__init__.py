"""Foundations every other folder builds on: vectors, batches of rays, random numbers, sampling warps and MIS,
colour and tonemapping, and Heckbert's path grammar. Nothing here imports the rest of the tracer."""
