"""Labels from a person: labeling batches out, filled label files and Label Studio in.

- ``batch``: ``write_batch`` (a batch's pictures, ``classes.csv``, ``to_label.csv``
  and its Label Studio import) and ``read_label_file`` (a filled ``to_label.csv`` or a
  Label Studio export, checked against the batch);
- ``label_studio``: batches as Label Studio imports with pre-annotations, JSON exports
  read as label files, brush RLE.

The label-file format itself and the labels a run keeps (``save_labels``,
``load_labels``, ``labels_for``) sit lower, in ``spl_al.data.label_files``, where the
data layer (``data.unlabeled_folder``) and training read them without this package.
"""

from spl_al.labeling.batch import read_label_file, write_batch

__all__ = ["read_label_file", "write_batch"]
