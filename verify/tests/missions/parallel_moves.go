// D1 is asked to fly forward and backward at once; the photo may run beside.
package Pull

var D1 Quadcopter

func PAR_Main() {
	D1.FlyByX(1)
	D1.FlyByX(-1)
	D1.TakePhoto()
}
