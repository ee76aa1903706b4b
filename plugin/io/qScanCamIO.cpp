#include "qScanCamIO.h"

#include "e57_filter.h"

qScanCamIO::qScanCamIO(QObject* parent)
    : QObject(parent), ccIOPluginInterface(":/CC/plugin/qScanCamIO/io_info.json") {}

ccIOPluginInterface::FilterList qScanCamIO::getFilters() {
  return {FileIOFilter::Shared(new scancam::plugin::io::E57Filter)};
}
