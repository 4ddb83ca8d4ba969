"""Applications built on :mod:`belief`.  They import it; it never imports them."""
