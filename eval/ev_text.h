/* ev_text: a built-in 5x7 bitmap font (printable ASCII, drawn for this project) for labels in
 * report images, so labelled grids need no font files or extra library.
 *
 * Glyph cells are EV_TEXT_ADV x EV_TEXT_LINE pixels at scale 1 (5x7 ink plus one column and two
 * rows of spacing); scale s multiplies both (nearest neighbour). Characters outside 32..126 are
 * drawn as '?'. Pixels are written with the given colour into a linear float image; nothing is
 * drawn outside the image. */
#ifndef EV_TEXT_H
#define EV_TEXT_H

#include "io/mf_image.h"

#define EV_TEXT_ADV 6
#define EV_TEXT_LINE 9

/* Width in pixels of text at scale s (n characters x EV_TEXT_ADV x s). */
int ev_text_width(const char *text, int scale);
/* Draws text with its top-left corner at (x, y); color: (img->c,) values, or NULL for 1 in every
 * channel. At most max_w pixels wide (<= 0: no limit): characters that do not fit are dropped and
 * the last one kept is replaced by '~' to show the cut. */
void ev_text_draw(MfImage *img, int x, int y, const char *text, int scale, const float *color, int max_w);

#endif
