"""Second algorithms the tests compare against (not part of the product)."""
