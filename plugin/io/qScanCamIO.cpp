#include "qScanCamIO.h"

#include "e57_filter.h"
#include "lidar_filters.h"

qScanCamIO::qScanCamIO(QObject* parent)
    : QObject(parent), ccIOPluginInterface(":/CC/plugin/qScanCamIO/io_info.json") {}

ccIOPluginInterface::FilterList qScanCamIO::getFilters() {
  return {FileIOFilter::Shared(new scancam::plugin::io::E57Filter),
          FileIOFilter::Shared(new scancam::plugin::io::PcdFilter),
          FileIOFilter::Shared(new scancam::plugin::io::KittiBinFilter)};
}
