"""What every layer of the project may use: the one file writer, the HTML page and the
command lines' parser."""
