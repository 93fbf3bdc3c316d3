"""File formats: renders written as EXR and PNG, images read as bitmaps, meshes read from
PLY, OBJ and Mitsuba's serialized files. Each module is imported by name; this package
imports none of them, so that a reader does not pull in the render driver."""
