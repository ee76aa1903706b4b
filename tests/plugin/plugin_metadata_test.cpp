// The built plugin carries the metadata CloudCompare 2.11.3 needs to list it.
#include <QJsonArray>
#include <QJsonObject>
#include <QPluginLoader>
#include <QtTest>

class PluginMetadataTest : public QObject {
  Q_OBJECT
 private slots:
  void hasStandardPluginMetadata() {
    QPluginLoader loader(QStringLiteral(SCANCAM_PLUGIN_FILE));
    const QJsonObject meta = loader.metaData();
    QVERIFY2(!meta.isEmpty(), qPrintable("no Qt plugin metadata in " + loader.fileName()));
    QCOMPARE(meta.value("IID").toString(), QStringLiteral("cccorp.cloudcompare.plugin.qScanCam"));
    const QJsonObject data = meta.value("MetaData").toObject();
    QCOMPARE(data.value("type").toString(), QStringLiteral("Standard"));
    QVERIFY(data.value("name").toString().startsWith("ScanCam"));
    QVERIFY(!data.value("description").toString().isEmpty());
    QVERIFY(data.value("icon").toString().startsWith(":/CC/plugin/qScanCam/"));
  }
  // qScanCamIO (the E57 filter): CloudCompare 2.11 registers file filters only from "I/O" plugins.
  void hasIoPluginMetadata() {
    QPluginLoader loader(QStringLiteral(SCANCAM_IO_PLUGIN_FILE));
    const QJsonObject meta = loader.metaData();
    QVERIFY2(!meta.isEmpty(), qPrintable("no Qt plugin metadata in " + loader.fileName()));
    QCOMPARE(meta.value("IID").toString(), QStringLiteral("cccorp.cloudcompare.plugin.qScanCamIO"));
    const QJsonObject data = meta.value("MetaData").toObject();
    QCOMPARE(data.value("type").toString(), QStringLiteral("I/O"));
    QVERIFY(data.value("name").toString().startsWith("ScanCam E57"));
    QVERIFY(data.value("icon").toString().startsWith(":/CC/plugin/qScanCamIO/"));
  }
};

QTEST_GUILESS_MAIN(PluginMetadataTest)
#include "plugin_metadata_test.moc"
