"""Recognition: the back-end every reader uses. A reader (app/cnc/formats/*) turns a file
into steps (moves with their lines); the segmenter groups the steps into operations
(holes, contours, routines, helices), recognition finds the patterns a machinist would
have typed (bolt circles, LOOP/REP, CIRCLE/FRAME routines, cutter compensation), and the
builder writes them as blocks with a report (docs/imports.md)."""
